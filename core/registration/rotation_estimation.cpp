#include "core/registration/rotation_estimation.h"

#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include <immintrin.h>

#include <Eigen/Dense>

#include "core/common/cpu.h"
#include "core/common/option_fields.h"

namespace evermap::core {

namespace {

// The template pixels of image a, one array per quantity (8 at a time on AVX2).
struct TemplatePixels {
  std::vector<float> ray_x, ray_y;  // normalised coordinates of the pixel of image a
  std::vector<float> value;
  std::vector<float> sd[4];  // steepest descent: ∇I_a · ∂W/∂ω, and 1 for the offset
  size_t size() const { return value.size(); }
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

// The warp of one iteration: pixel ray (x, y, 1) turned by Rm, projected with the level's
// intrinsics.
struct Warp {
  Eigen::Matrix3f Rm;
  float fx, fy, cx, cy, offset;
};

// One template pixel: adds its steepest-descent image times its error to g; false when it
// falls behind the camera or outside image b.
inline bool accumulate(const TemplatePixels& t, size_t i, const Warp& w, const cv::Mat& image_b,
                       Eigen::Vector4f* g) {
  const Eigen::Vector3f q = w.Rm.col(0) * t.ray_x[i] + w.Rm.col(1) * t.ray_y[i] + w.Rm.col(2);
  if (q.z() <= 1e-3f) return false;
  const float iz = 1.0f / q.z();
  float value;
  if (!sampleBilinear(image_b, w.fx * q.x() * iz + w.cx, w.fy * q.y() * iz + w.cy, &value)) {
    return false;
  }
  const float e = value - t.value[i] - w.offset;
  for (int k = 0; k < 4; ++k) (*g)(k) += t.sd[k][i] * e;
  return true;
}

int accumulateScalar(const TemplatePixels& t, const Warp& w, const cv::Mat& image_b,
                     Eigen::Vector4f* g) {
  int used = 0;
  for (size_t i = 0; i < t.size(); ++i) used += accumulate(t, i, w, image_b, g) ? 1 : 0;
  return used;
}

// The warp's constants broadcast to 8 lanes, for accumulateAvx2.
struct Avx2Constants {
  __m256 r00, r01, r02, r10, r11, r12, r20, r21, r22;
  __m256 fx, fy, cx, cy, offset, one, min_z;
  __m256i zero_i, one_i, cols_minus_2, cols_minus_1, rows_minus_1, steps, byte;
};

__attribute__((target("avx2"))) void broadcast(const Warp& w, const cv::Mat& image_b,
                                               Avx2Constants* c) {
  const int step = static_cast<int>(image_b.step[0]);
  c->r00 = _mm256_set1_ps(w.Rm(0, 0));
  c->r01 = _mm256_set1_ps(w.Rm(0, 1));
  c->r02 = _mm256_set1_ps(w.Rm(0, 2));
  c->r10 = _mm256_set1_ps(w.Rm(1, 0));
  c->r11 = _mm256_set1_ps(w.Rm(1, 1));
  c->r12 = _mm256_set1_ps(w.Rm(1, 2));
  c->r20 = _mm256_set1_ps(w.Rm(2, 0));
  c->r21 = _mm256_set1_ps(w.Rm(2, 1));
  c->r22 = _mm256_set1_ps(w.Rm(2, 2));
  c->fx = _mm256_set1_ps(w.fx);
  c->fy = _mm256_set1_ps(w.fy);
  c->cx = _mm256_set1_ps(w.cx);
  c->cy = _mm256_set1_ps(w.cy);
  c->offset = _mm256_set1_ps(w.offset);
  c->one = _mm256_set1_ps(1.0f);
  c->min_z = _mm256_set1_ps(1e-3f);
  c->zero_i = _mm256_setzero_si256();
  c->one_i = _mm256_set1_epi32(1);
  c->cols_minus_2 = _mm256_set1_epi32(image_b.cols - 2);
  c->cols_minus_1 = _mm256_set1_epi32(image_b.cols - 1);
  c->rows_minus_1 = _mm256_set1_epi32(image_b.rows - 1);
  c->steps = _mm256_set1_epi32(step);
  c->byte = _mm256_set1_epi32(0xff);
}

// Template pixels i .. i + 7 warped into image b: where they land (u, v), the pixel below-left
// of it (x0, y0), and which lanes are inside (the scalar rule: x0 >= 0, x0 + 1 < cols, same
// for rows) and gatherable (also x0 >= 1, x0 + 2 < cols). Lanes behind the camera have
// garbage x0, y0: masked.
struct Avx2Lanes {
  __m256 u, v, fu, fv;
  __m256i x0, y0, inside, gatherable;
};

__attribute__((target("avx2"))) void warpLanes(const Avx2Constants& c, const TemplatePixels& t,
                                               size_t i, Avx2Lanes* l) {
  const __m256 rx = _mm256_loadu_ps(t.ray_x.data() + i);
  const __m256 ry = _mm256_loadu_ps(t.ray_y.data() + i);
  const __m256 qx =
      _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(c.r00, rx), _mm256_mul_ps(c.r01, ry)), c.r02);
  const __m256 qy =
      _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(c.r10, rx), _mm256_mul_ps(c.r11, ry)), c.r12);
  const __m256 qz =
      _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(c.r20, rx), _mm256_mul_ps(c.r21, ry)), c.r22);
  const __m256 front = _mm256_cmp_ps(qz, c.min_z, _CMP_GT_OQ);
  const __m256 iz = _mm256_div_ps(c.one, qz);
  l->u = _mm256_add_ps(_mm256_mul_ps(_mm256_mul_ps(c.fx, qx), iz), c.cx);
  l->v = _mm256_add_ps(_mm256_mul_ps(_mm256_mul_ps(c.fy, qy), iz), c.cy);
  l->fu = _mm256_floor_ps(l->u);
  l->fv = _mm256_floor_ps(l->v);
  l->x0 = _mm256_cvttps_epi32(l->fu);
  l->y0 = _mm256_cvttps_epi32(l->fv);
  const __m256i rows_in = _mm256_andnot_si256(
      _mm256_or_si256(_mm256_cmpgt_epi32(c.zero_i, l->y0),
                      _mm256_cmpgt_epi32(l->y0, _mm256_sub_epi32(c.rows_minus_1, c.one_i))),
      _mm256_castps_si256(front));
  l->inside = _mm256_andnot_si256(
      _mm256_or_si256(_mm256_cmpgt_epi32(c.zero_i, l->x0),
                      _mm256_cmpgt_epi32(l->x0, _mm256_sub_epi32(c.cols_minus_1, c.one_i))),
      rows_in);
  l->gatherable = _mm256_andnot_si256(
      _mm256_or_si256(_mm256_cmpgt_epi32(c.one_i, l->x0),
                      _mm256_cmpgt_epi32(l->x0, _mm256_sub_epi32(c.cols_minus_2, c.one_i))),
      l->inside);
}

// The bilinear sample of image b at the gatherable lanes (0 elsewhere): the four neighbours
// of a sample come from two 32-bit gathers (bytes x0 - 1 .. x0 + 2 of rows y0 and y0 + 1).
__attribute__((target("avx2"))) __m256 sampleLanes(const Avx2Constants& c, const Avx2Lanes& l,
                                                   const cv::Mat& image_b) {
  const auto* base = reinterpret_cast<const int*>(image_b.ptr<uint8_t>(0));
  const __m256i index =
      _mm256_add_epi32(_mm256_mullo_epi32(l.y0, c.steps), _mm256_sub_epi32(l.x0, c.one_i));
  const __m256i w0 = _mm256_mask_i32gather_epi32(c.zero_i, base, index, l.gatherable, 1);
  const __m256i w1 = _mm256_mask_i32gather_epi32(c.zero_i, base, _mm256_add_epi32(index, c.steps),
                                                 l.gatherable, 1);
  const __m256 p00 = _mm256_cvtepi32_ps(_mm256_and_si256(_mm256_srli_epi32(w0, 8), c.byte));
  const __m256 p01 = _mm256_cvtepi32_ps(_mm256_and_si256(_mm256_srli_epi32(w0, 16), c.byte));
  const __m256 p10 = _mm256_cvtepi32_ps(_mm256_and_si256(_mm256_srli_epi32(w1, 8), c.byte));
  const __m256 p11 = _mm256_cvtepi32_ps(_mm256_and_si256(_mm256_srli_epi32(w1, 16), c.byte));
  const __m256 ax = _mm256_sub_ps(l.u, l.fu), ay = _mm256_sub_ps(l.v, l.fv);
  const __m256 bx = _mm256_sub_ps(c.one, ax), by = _mm256_sub_ps(c.one, ay);
  return _mm256_add_ps(
      _mm256_mul_ps(by, _mm256_add_ps(_mm256_mul_ps(bx, p00), _mm256_mul_ps(ax, p01))),
      _mm256_mul_ps(ay, _mm256_add_ps(_mm256_mul_ps(bx, p10), _mm256_mul_ps(ax, p11))));
}

// The same as accumulateScalar, 8 pixels at a time (warpLanes, sampleLanes). Samples whose
// gather would leave the image row (x0 = 0 or x0 + 2 = cols) and the last pixels take the
// scalar path.
__attribute__((target("avx2"))) int accumulateAvx2(const TemplatePixels& t, const Warp& w,
                                                   const cv::Mat& image_b, Eigen::Vector4f* g) {
  const size_t n = t.size();
  const size_t n8 = n / 8 * 8;
  Avx2Constants c;
  broadcast(w, image_b, &c);
  __m256 g0 = _mm256_setzero_ps(), g1 = g0, g2 = g0, g3 = g0;
  int used = 0;
  Eigen::Vector4f g_scalar = Eigen::Vector4f::Zero();
  for (size_t i = 0; i < n8; i += 8) {
    Avx2Lanes l;
    warpLanes(c, t, i, &l);
    const int inside_bits = _mm256_movemask_ps(_mm256_castsi256_ps(l.inside));
    const int gather_bits = _mm256_movemask_ps(_mm256_castsi256_ps(l.gatherable));
    if (inside_bits != gather_bits) {  // a sample on the first or last column
      for (int k = 0; k < 8; ++k) {
        if ((inside_bits & ~gather_bits) >> k & 1) {
          used += accumulate(t, i + static_cast<size_t>(k), w, image_b, &g_scalar) ? 1 : 0;
        }
      }
    }
    if (gather_bits == 0) continue;
    used += __builtin_popcount(static_cast<unsigned>(gather_bits));
    const __m256 value = sampleLanes(c, l, image_b);
    const __m256 e = _mm256_and_ps(
        _mm256_sub_ps(_mm256_sub_ps(value, _mm256_loadu_ps(t.value.data() + i)), c.offset),
        _mm256_castsi256_ps(l.gatherable));
    g0 = _mm256_add_ps(g0, _mm256_mul_ps(_mm256_loadu_ps(t.sd[0].data() + i), e));
    g1 = _mm256_add_ps(g1, _mm256_mul_ps(_mm256_loadu_ps(t.sd[1].data() + i), e));
    g2 = _mm256_add_ps(g2, _mm256_mul_ps(_mm256_loadu_ps(t.sd[2].data() + i), e));
    g3 = _mm256_add_ps(g3, _mm256_mul_ps(_mm256_loadu_ps(t.sd[3].data() + i), e));
  }
  for (size_t i = n8; i < n; ++i) used += accumulate(t, i, w, image_b, &g_scalar) ? 1 : 0;
  alignas(32) float s[4][8];
  _mm256_store_ps(s[0], g0);
  _mm256_store_ps(s[1], g1);
  _mm256_store_ps(s[2], g2);
  _mm256_store_ps(s[3], g3);
  for (int k = 0; k < 4; ++k) {
    float sum = g_scalar(k);
    for (int l = 0; l < 8; ++l) sum += s[k][l];
    (*g)(k) += sum;
  }
  return used;
}

}  // namespace

void RotationEstimateOptions::declareOptions(OptionList& o) {
  o.add("max_iterations", &max_iterations, "iterations", "Gauss-Newton iterations at most").min(1);
  o.add("converged_rad", &converged_rad, "rad", "a step below this ends the iterations").positive();
  o.add("max_angle_rad", &max_angle_rad, "rad",
        "a rotation larger than this between two frames is refused")
      .positive();
  o.add("border_px", &border_px, "px", "pixels of the level left out around the border")
      .nonNegative();
  o.add("min_gradient", &min_gradient, "gray levels/px",
        "pixels whose gradient |gx| + |gy| is below this are left out")
      .nonNegative();
}

std::optional<SO3d> estimateRotation(const cv::Mat& image_a, const cv::Mat& image_b,
                                     const StereoCamera& camera, int level,
                                     const RotationEstimateOptions& options, const SO3d& initial) {
  if (image_a.empty() || image_a.size() != image_b.size() || image_a.type() != CV_8UC1 ||
      image_b.type() != CV_8UC1 || level < 0 || level > 8) {
    return std::nullopt;
  }
  const double s = 1.0 / static_cast<double>(1 << level);
  const double fx = camera.fx() * s, fy = camera.fy() * s;
  const double cx = camera.cx() * s, cy = camera.cy() * s;
  const int b = std::max(options.border_px, 1);

  TemplatePixels pixels;
  Eigen::Matrix4d H = Eigen::Matrix4d::Zero();
  for (int y = b; y < image_a.rows - b; ++y) {
    const uint8_t* row = image_a.ptr<uint8_t>(y);
    const uint8_t* up = image_a.ptr<uint8_t>(y - 1);
    const uint8_t* down = image_a.ptr<uint8_t>(y + 1);
    for (int x = b; x < image_a.cols - b; ++x) {
      const float gx = 0.5f * (static_cast<float>(row[x + 1]) - row[x - 1]);
      const float gy = 0.5f * (static_cast<float>(down[x]) - up[x]);
      if (std::abs(gx) + std::abs(gy) < options.min_gradient) continue;
      const double na = (x - cx) / fx, nb = (y - cy) / fy;
      const Eigen::Vector3d du(-na * nb, 1.0 + na * na, -nb);
      const Eigen::Vector3d dv(-(1.0 + nb * nb), na * nb, na);
      Eigen::Vector4f sd;
      sd.head<3>() = (gx * fx * du + gy * fy * dv).cast<float>();
      sd(3) = 1.0f;
      H += sd.cast<double>() * sd.cast<double>().transpose();
      pixels.ray_x.push_back(static_cast<float>(na));
      pixels.ray_y.push_back(static_cast<float>(nb));
      pixels.value.push_back(row[x]);
      for (int k = 0; k < 4; ++k) pixels.sd[k].push_back(sd(k));
    }
  }
  if (pixels.size() < 100) return std::nullopt;
  Eigen::LDLT<Eigen::Matrix4d> ldlt(H);
  if (ldlt.info() != Eigen::Success || !(ldlt.vectorD().minCoeff() > 1e-9 * H.trace())) {
    return std::nullopt;
  }

  // The gathers index the image with 32-bit byte offsets.
  const bool avx2 = cpuHasAvx2() && static_cast<int64_t>(image_b.rows) * image_b.step[0] <
                                        static_cast<int64_t>(std::numeric_limits<int>::max());
  SO3d R = initial;  // b_R_a
  double offset = 0.0;
  for (int it = 0; it < options.max_iterations; ++it) {
    const Warp warp{R.matrix().cast<float>(), static_cast<float>(fx), static_cast<float>(fy),
                    static_cast<float>(cx),   static_cast<float>(cy), static_cast<float>(offset)};
    Eigen::Vector4f g = Eigen::Vector4f::Zero();
    const int used = avx2 ? accumulateAvx2(pixels, warp, image_b, &g)
                          : accumulateScalar(pixels, warp, image_b, &g);
    if (used < static_cast<int>(pixels.size() / 4)) return std::nullopt;
    const Eigen::Vector4d delta = ldlt.solve(g.cast<double>());
    if (!delta.allFinite()) return std::nullopt;
    R = R * SO3d::exp(-delta.head<3>());
    offset += delta(3);
    if (rotationAngle(R) > options.max_angle_rad) return std::nullopt;
    if (delta.head<3>().norm() < options.converged_rad) break;
  }
  return R;
}

}  // namespace evermap::core
