#include "core/registration/rotation_estimation.h"

#include <cmath>
#include <vector>

#include <Eigen/Dense>

namespace evermap::core {

namespace {

struct TemplatePixel {
  float ray_x, ray_y;            // normalised coordinates of the pixel of image a
  float value;
  Eigen::Matrix<float, 4, 1> sd; // steepest descent: ∇I_a · ∂W/∂ω, and 1 for the offset
};

inline bool sampleBilinear(const cv::Mat& image, float x, float y, float* out) {
  const float fx = std::floor(x), fy = std::floor(y);
  const int x0 = static_cast<int>(fx), y0 = static_cast<int>(fy);
  if (x0 < 0 || y0 < 0 || x0 + 1 >= image.cols || y0 + 1 >= image.rows) return false;
  const float ax = x - fx, ay = y - fy;
  const uint8_t* r0 = image.ptr<uint8_t>(y0) + x0;
  const uint8_t* r1 = image.ptr<uint8_t>(y0 + 1) + x0;
  *out = (1 - ay) * ((1 - ax) * r0[0] + ax * r0[1]) + ay * ((1 - ax) * r1[0] + ax * r1[1]);
  return true;
}

}  // namespace

std::optional<SO3d> estimateRotation(const cv::Mat& image_a, const cv::Mat& image_b,
                                     const StereoCamera& camera, int level,
                                     const RotationEstimateOptions& options) {
  if (image_a.empty() || image_a.size() != image_b.size() || image_a.type() != CV_8UC1 ||
      image_b.type() != CV_8UC1 || level < 0 || level > 8) {
    return std::nullopt;
  }
  const double s = 1.0 / static_cast<double>(1 << level);
  const double fx = camera.fx() * s, fy = camera.fy() * s;
  const double cx = camera.cx() * s, cy = camera.cy() * s;
  const int b = std::max(options.border_px, 1);

  // Template pixels with a gradient: ∂(u, v)/∂ω of the rotated ray at ω = 0, for the
  // normalised point (a, b) (first order of exp(ω) r ≈ r + ω × r, then the projection):
  //   ∂u/∂ω = fx (-a b, 1 + a², -b),   ∂v/∂ω = fy (-(1 + b²), a b, a).
  std::vector<TemplatePixel> pixels;
  pixels.reserve(static_cast<size_t>(image_a.cols * image_a.rows));
  Eigen::Matrix4d H = Eigen::Matrix4d::Zero();
  for (int y = b; y < image_a.rows - b; ++y) {
    const uint8_t* row = image_a.ptr<uint8_t>(y);
    const uint8_t* up = image_a.ptr<uint8_t>(y - 1);
    const uint8_t* down = image_a.ptr<uint8_t>(y + 1);
    for (int x = b; x < image_a.cols - b; ++x) {
      const float gx = 0.5f * (static_cast<float>(row[x + 1]) - row[x - 1]);
      const float gy = 0.5f * (static_cast<float>(down[x]) - up[x]);
      // Flat pixels carry no information; the threshold also halves the work on typical
      // images (the estimate only has to be good to a few pixels of level 0).
      if (std::abs(gx) + std::abs(gy) < options.min_gradient) continue;
      const double na = (x - cx) / fx, nb = (y - cy) / fy;
      const Eigen::Vector3d du(-na * nb, 1.0 + na * na, -nb);
      const Eigen::Vector3d dv(-(1.0 + nb * nb), na * nb, na);
      TemplatePixel p;
      p.ray_x = static_cast<float>(na);
      p.ray_y = static_cast<float>(nb);
      p.value = row[x];
      p.sd.head<3>() = (gx * fx * du + gy * fy * dv).cast<float>();
      p.sd(3) = 1.0f;
      H += p.sd.cast<double>() * p.sd.cast<double>().transpose();
      pixels.push_back(p);
    }
  }
  if (pixels.size() < 100) return std::nullopt;
  Eigen::LDLT<Eigen::Matrix4d> ldlt(H);
  if (ldlt.info() != Eigen::Success || !(ldlt.vectorD().minCoeff() > 1e-9 * H.trace())) {
    return std::nullopt;
  }

  SO3d R;  // b_R_a
  double offset = 0.0;
  for (int it = 0; it < options.max_iterations; ++it) {
    const Eigen::Matrix3f Rm = R.matrix().cast<float>();
    // Accumulated in float per pixel, in double per iteration.
    Eigen::Vector4f g = Eigen::Vector4f::Zero();
    int used = 0;
    const float fo = static_cast<float>(offset);
    for (const TemplatePixel& p : pixels) {
      const Eigen::Vector3f q = Rm.col(0) * p.ray_x + Rm.col(1) * p.ray_y + Rm.col(2);
      if (q.z() <= 1e-3f) continue;
      const float iz = 1.0f / q.z();
      const float u = static_cast<float>(fx) * q.x() * iz + static_cast<float>(cx);
      const float v = static_cast<float>(fy) * q.y() * iz + static_cast<float>(cy);
      float value;
      if (!sampleBilinear(image_b, u, v, &value)) continue;
      g += p.sd * (value - p.value - fo);
      ++used;
    }
    if (used < static_cast<int>(pixels.size() / 4)) return std::nullopt;
    const Eigen::Vector4d delta = ldlt.solve(g.cast<double>());
    if (!delta.allFinite()) return std::nullopt;
    // Inverse composition: the template side moved by exp(δω), so R ← R exp(-δω).
    R = R * SO3d::exp(-delta.head<3>());
    offset += delta(3);
    if (rotationAngle(R) > options.max_angle_rad) return std::nullopt;
    if (delta.head<3>().norm() < options.converged_rad) break;
  }
  return R;
}

}  // namespace evermap::core
