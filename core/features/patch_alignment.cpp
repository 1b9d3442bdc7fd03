#include "core/features/patch_alignment.h"

#include <cmath>

#include <immintrin.h>

#include <Eigen/Dense>  // Matrix3d::inverse

#include "core/common/cpu.h"
#include "core/common/option_fields.h"

namespace evermap::core {

namespace {

constexpr int kMaxRadius = 8;
constexpr int kMaxSide = 2 * kMaxRadius + 1;
constexpr int kStride = 24;  // floats per template row: kMaxSide rounded up to whole vectors
static_assert(kStride % 8 == 0 && kStride >= 16,
              "template rows are read as one or two 8-float vectors");

// The template of a, its gradient and a lane mask, one patch row per kStride floats; lanes
// past the patch side are 0 (gradient, mask), so a row can be summed in whole 8-float vectors.
struct Template {
  alignas(32) float t[kMaxSide][kStride];
  alignas(32) float gx[kMaxSide][kStride];
  alignas(32) float gy[kMaxSide][kStride];
  alignas(32) float mask[kStride];
  // Normal equations of the inverse-compositional step over (dx, dy, offset): H = Σ g gᵀ with
  // g = (∂T/∂x, ∂T/∂y, 1), constant over the iterations.
  float hxx = 0, hxy = 0, hx1 = 0, hyy = 0, hy1 = 0;
};

// The AVX2 path: patches up to 16 pixels wide (radius 7) whose rows of 8 or 16 pixels, plus
// one, lie inside the image; the scalar path below does the rest, and all of it on a CPU
// without AVX2. The two differ only in the order of the float sums.
int vectorsPerRow(int side) { return side <= 8 ? 1 : 2; }

// 8 pixels from p as floats.
__attribute__((target("avx2"), always_inline)) inline __m256 pixels(const uint8_t* p) {
  return _mm256_cvtepi32_ps(
      _mm256_cvtepu8_epi32(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(p))));
}

__attribute__((target("avx2"))) float sum8(__m256 v) {
  alignas(32) float x[8];
  _mm256_store_ps(x, v);
  return ((x[0] + x[1]) + (x[2] + x[3])) + ((x[4] + x[5]) + (x[6] + x[7]));
}

// The template of the patch of a around (ua, va).
__attribute__((target("avx2"))) void templateAvx2(const cv::Mat& a, int ua, int va, int r,
                                                  bool x_only, Template* tp) {
  const int side = 2 * r + 1;
  const __m256 half = _mm256_set1_ps(0.5f);
  __m256 hxx = _mm256_setzero_ps(), hxy = hxx, hx1 = hxx, hyy = hxx, hy1 = hxx;
  for (int row = 0; row < side; ++row) {
    const uint8_t* p = a.ptr<uint8_t>(va - r + row) + (ua - r);
    const uint8_t* up = a.ptr<uint8_t>(va - r + row - 1) + (ua - r);
    const uint8_t* down = a.ptr<uint8_t>(va - r + row + 1) + (ua - r);
    for (int k = 0; k < vectorsPerRow(side); ++k) {
      const int o = 8 * k;
      const __m256 mask = _mm256_load_ps(tp->mask + o);
      const __m256 gx = _mm256_mul_ps(
          _mm256_mul_ps(half, _mm256_sub_ps(pixels(p + o + 1), pixels(p + o - 1))), mask);
      const __m256 gy =
          x_only ? _mm256_setzero_ps()
                 : _mm256_mul_ps(
                       _mm256_mul_ps(half, _mm256_sub_ps(pixels(down + o), pixels(up + o))), mask);
      _mm256_store_ps(tp->t[row] + o, pixels(p + o));
      _mm256_store_ps(tp->gx[row] + o, gx);
      _mm256_store_ps(tp->gy[row] + o, gy);
      hxx = _mm256_add_ps(hxx, _mm256_mul_ps(gx, gx));
      hxy = _mm256_add_ps(hxy, _mm256_mul_ps(gx, gy));
      hx1 = _mm256_add_ps(hx1, gx);
      hyy = _mm256_add_ps(hyy, _mm256_mul_ps(gy, gy));
      hy1 = _mm256_add_ps(hy1, gy);
    }
  }
  tp->hxx = sum8(hxx);
  tp->hxy = sum8(hxy);
  tp->hx1 = sum8(hx1);
  tp->hyy = sum8(hyy);
  tp->hy1 = sum8(hy1);
}

void templateScalar(const cv::Mat& a, int ua, int va, int r, bool x_only, Template* tp) {
  for (int dy = -r; dy <= r; ++dy) {
    const uint8_t* row = a.ptr<uint8_t>(va + dy);
    const uint8_t* up = a.ptr<uint8_t>(va + dy - 1);
    const uint8_t* down = a.ptr<uint8_t>(va + dy + 1);
    float* t = tp->t[dy + r] + r;
    float* gx = tp->gx[dy + r] + r;
    float* gy = tp->gy[dy + r] + r;
    for (int dx = -r; dx <= r; ++dx) {
      const int x = ua + dx;
      t[dx] = row[x];
      gx[dx] = 0.5f * (static_cast<float>(row[x + 1]) - row[x - 1]);
      gy[dx] = x_only ? 0.0f : 0.5f * (static_cast<float>(down[x]) - up[x]);
      tp->hxx += gx[dx] * gx[dx];
      tp->hxy += gx[dx] * gy[dx];
      tp->hx1 += gx[dx];
      tp->hyy += gy[dx] * gy[dx];
      tp->hy1 += gy[dx];
    }
  }
}

// Σ gx e, Σ gy e, Σ e over the patch of b at integer (x0 - r, y0 - r) with bilinear weights,
// e = b - t - offset. `vertical`: false when the weights of the next row are 0 (1-D case).
__attribute__((target("avx2"))) Eigen::Vector3d sumsAvx2(const Template& tp, const cv::Mat& b,
                                                         int x0, int y0, int r, float w00,
                                                         float w01, float w10, float w11,
                                                         float offset, bool vertical) {
  const int side = 2 * r + 1;
  const __m256 W00 = _mm256_set1_ps(w00), W01 = _mm256_set1_ps(w01);
  const __m256 W10 = _mm256_set1_ps(w10), W11 = _mm256_set1_ps(w11);
  const __m256 off = _mm256_set1_ps(offset);
  __m256 sx = _mm256_setzero_ps(), sy = _mm256_setzero_ps(), s1 = _mm256_setzero_ps();
  for (int row = 0; row < side; ++row) {
    const uint8_t* r0 = b.ptr<uint8_t>(y0 - r + row) + (x0 - r);
    const uint8_t* r1 = b.ptr<uint8_t>(y0 - r + row + 1) + (x0 - r);
    for (int k = 0; k < vectorsPerRow(side); ++k) {
      const int o = 8 * k;
      __m256 s =
          _mm256_add_ps(_mm256_mul_ps(W00, pixels(r0 + o)), _mm256_mul_ps(W01, pixels(r0 + o + 1)));
      if (vertical) {
        s = _mm256_add_ps(s, _mm256_add_ps(_mm256_mul_ps(W10, pixels(r1 + o)),
                                           _mm256_mul_ps(W11, pixels(r1 + o + 1))));
      }
      const __m256 e =
          _mm256_mul_ps(_mm256_sub_ps(_mm256_sub_ps(s, _mm256_load_ps(tp.t[row] + o)), off),
                        _mm256_load_ps(tp.mask + o));
      sx = _mm256_add_ps(sx, _mm256_mul_ps(_mm256_load_ps(tp.gx[row] + o), e));
      sy = _mm256_add_ps(sy, _mm256_mul_ps(_mm256_load_ps(tp.gy[row] + o), e));
      s1 = _mm256_add_ps(s1, e);
    }
  }
  return Eigen::Vector3d(sum8(sx), sum8(sy), sum8(s1));
}

Eigen::Vector3d sumsScalar(const Template& tp, const cv::Mat& b, int x0, int y0, int r, float w00,
                           float w01, float w10, float w11, float offset) {
  float sx = 0, sy = 0, s1 = 0;
  for (int dy = -r; dy <= r; ++dy) {
    const uint8_t* r0 = b.ptr<uint8_t>(y0 + dy) + x0;
    const uint8_t* r1 = b.ptr<uint8_t>(y0 + dy + 1) + x0;
    const float* t = tp.t[dy + r] + r;
    const float* gx = tp.gx[dy + r] + r;
    const float* gy = tp.gy[dy + r] + r;
    for (int dx = -r; dx <= r; ++dx) {
      const float s = w00 * r0[dx] + w01 * r0[dx + 1] + w10 * r1[dx] + w11 * r1[dx + 1];
      const float e = s - t[dx] - offset;
      sx += gx[dx] * e;
      sy += gy[dx] * e;
      s1 += e;
    }
  }
  return Eigen::Vector3d(sx, sy, s1);
}

}  // namespace

void PatchAlignmentOptions::declareOptions(OptionList& o) {
  o.add("radius_px", &radius_px, "px", "template (2r+1)^2").in(1, kMaxRadius);
  o.add("x_only", &x_only, "align along the row only (rectified stereo)");
  o.add("max_iterations", &max_iterations, "iterations", "Gauss-Newton iterations at most").min(1);
  o.add("max_shift_px", &max_shift_px, "px",
        "moving farther from the start means the discrete match was wrong")
      .positive();
  o.add("converged_px", &converged_px, "px", "a step below this ends the iterations").positive();
}

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
  const bool avx2 = side <= 16 && cpuHasAvx2();
  // A vector row reads 8 or 16 pixels and the one after them.
  const int row_reach = 8 * vectorsPerRow(side) + 1;
  Template tp;
  if (avx2) {
    for (int k = 0; k < kStride; ++k) tp.mask[k] = k < side ? 1.0f : 0.0f;
  }
  if (avx2 && ua - r + row_reach <= a.cols) {
    templateAvx2(a, ua, va, r, options.x_only, &tp);
  } else {
    if (avx2) {  // the vector sums below read whole rows: lanes past the side must be 0
      for (int row = 0; row < side; ++row) {
        for (int k = side; k < kStride; ++k) tp.t[row][k] = tp.gx[row][k] = tp.gy[row][k] = 0;
      }
    }
    templateScalar(a, ua, va, r, options.x_only, &tp);
  }
  Eigen::Matrix3d H;
  H << tp.hxx, tp.hxy, tp.hx1, tp.hxy, tp.hyy, tp.hy1, tp.hx1, tp.hy1, n;
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
    const float w00 = (1 - ax) * (1 - ay), w01 = ax * (1 - ay), w10 = (1 - ax) * ay, w11 = ax * ay;
    // The next row's weights are 0 only when p.y() is a whole number; in the 1-D case p.y()
    // stays the start's, which need not be.
    const bool vertical = ay != 0.0f;
    const Eigen::Vector3d sums =
        avx2 && x0 - r + row_reach <= b.cols
            ? sumsAvx2(tp, b, x0, y0, r, w00, w01, w10, w11, offset, vertical)
            : sumsScalar(tp, b, x0, y0, r, w00, w01, w10, w11, offset);
    const Eigen::Vector3d delta = Hinv * sums;
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
