#include "core/features/patch_alignment.h"

#include <cmath>

#include <Eigen/Dense>  // Matrix3d::inverse

namespace evermap::core {

namespace {
constexpr int kMaxRadius = 8;
constexpr int kMaxSide = 2 * kMaxRadius + 1;
}  // namespace

std::optional<Eigen::Vector2f> alignPatch(const cv::Mat& a, int ua, int va, const cv::Mat& b,
                                          const Eigen::Vector2f& start,
                                          const PatchAlignmentOptions& options) {
  const int r = options.radius_px;
  if (r < 1 || r > kMaxRadius || a.type() != CV_8UC1 || b.type() != CV_8UC1) return std::nullopt;
  // The template and its central-difference gradient need one more pixel around it.
  if (ua - r - 1 < 0 || va - r - 1 < 0 || ua + r + 1 >= a.cols || va + r + 1 >= a.rows) {
    return std::nullopt;
  }
  const int side = 2 * r + 1;
  const int n = side * side;
  float t[kMaxSide * kMaxSide], gx[kMaxSide * kMaxSide], gy[kMaxSide * kMaxSide];
  // Normal equations of the inverse-compositional step over (dx, dy, offset): H = Σ g gᵀ with
  // g = (∂T/∂x, ∂T/∂y, 1), constant over the iterations.
  float hxx = 0, hxy = 0, hx1 = 0, hyy = 0, hy1 = 0;
  for (int dy = -r, i = 0; dy <= r; ++dy) {
    const uint8_t* row = a.ptr<uint8_t>(va + dy);
    const uint8_t* up = a.ptr<uint8_t>(va + dy - 1);
    const uint8_t* down = a.ptr<uint8_t>(va + dy + 1);
    for (int dx = -r; dx <= r; ++dx, ++i) {
      const int x = ua + dx;
      t[i] = row[x];
      gx[i] = 0.5f * (static_cast<float>(row[x + 1]) - row[x - 1]);
      gy[i] = options.x_only ? 0.0f : 0.5f * (static_cast<float>(down[x]) - up[x]);
      hxx += gx[i] * gx[i];
      hxy += gx[i] * gy[i];
      hx1 += gx[i];
      hyy += gy[i] * gy[i];
      hy1 += gy[i];
    }
  }
  Eigen::Matrix3d H;
  H << hxx, hxy, hx1, hxy, hyy, hy1, hx1, hy1, n;
  if (options.x_only) H(1, 1) = 1.0;  // dy is fixed: keep the system regular
  // Too little texture for a position (along x, or in both directions).
  if (H(0, 0) < 1e-3 * n ||
      (!options.x_only && H.topLeftCorner<2, 2>().determinant() < 1e-6 * n * n)) {
    return std::nullopt;
  }
  const Eigen::Matrix3d Hinv = H.inverse();
  if (!Hinv.allFinite()) return std::nullopt;

  Eigen::Vector2f p = start;
  float offset = 0.0f;
  for (int it = 0; it < options.max_iterations; ++it) {
    const float fx = std::floor(p.x()), fy = std::floor(p.y());
    const int x0 = static_cast<int>(fx), y0 = static_cast<int>(fy);
    if (x0 - r < 0 || y0 - r < 0 || x0 + r + 1 >= b.cols || y0 + r + 1 >= b.rows) {
      return std::nullopt;
    }
    const float ax = p.x() - fx, ay = p.y() - fy;
    const float w00 = (1 - ax) * (1 - ay), w01 = ax * (1 - ay), w10 = (1 - ax) * ay,
                w11 = ax * ay;
    float sx = 0, sy = 0, s1 = 0;
    if (options.x_only) {
      // The row stays the template's (ay = 0, so w10 = w11 = 0) and gy = 0: half the work of
      // the 2-D case below, with the same sums.
      for (int dy = -r, i = 0; dy <= r; ++dy) {
        const uint8_t* r0 = b.ptr<uint8_t>(y0 + dy) + x0;
        for (int dx = -r; dx <= r; ++dx, ++i) {
          const float e = w00 * r0[dx] + w01 * r0[dx + 1] - t[i] - offset;
          sx += gx[i] * e;
          s1 += e;
        }
      }
    } else {
      for (int dy = -r, i = 0; dy <= r; ++dy) {
        const uint8_t* r0 = b.ptr<uint8_t>(y0 + dy) + x0;
        const uint8_t* r1 = b.ptr<uint8_t>(y0 + dy + 1) + x0;
        for (int dx = -r; dx <= r; ++dx, ++i) {
          const float s = w00 * r0[dx] + w01 * r0[dx + 1] + w10 * r1[dx] + w11 * r1[dx + 1];
          const float e = s - t[i] - offset;
          sx += gx[i] * e;
          sy += gy[i] * e;
          s1 += e;
        }
      }
    }
    const Eigen::Vector3d delta = Hinv * Eigen::Vector3d(sx, sy, s1);
    // Inverse composition of a translation: the template moved by delta, so the target
    // position moves back by it; the offset is additive.
    p.x() -= static_cast<float>(delta.x());
    if (!options.x_only) p.y() -= static_cast<float>(delta.y());
    offset += static_cast<float>(delta.z());
    if (!std::isfinite(p.x()) || !std::isfinite(p.y()) ||
        (p - start).norm() > options.max_shift_px) {
      return std::nullopt;
    }
    if (std::abs(delta.x()) < options.converged_px &&
        (options.x_only || std::abs(delta.y()) < options.converged_px)) {
      break;
    }
  }
  return p;
}

}  // namespace evermap::core
