#include "core/features/stereo_depth.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>

#include <immintrin.h>

#include "core/common/cpu.h"
#include "core/common/option_fields.h"
#include "core/features/patch_alignment.h"

namespace evermap::core {

namespace {

constexpr int kMaxDisparity = 512;

// cost[j], j = 0..dmax: the SAD of the (2r+1)^2 window of L at (u, v) against R at
// (u - dmax + j, v), i.e. at disparity dmax - j: the inner loops run over contiguous right
// pixels. Computed in blocks of disparities whose sums stay in vector registers over the whole
// window; the last block overlaps the one before instead of reading past the search range.
// Exact integer sums: the AVX2 path and the portable one give the same costs.

// Blocks of 16 (GCC vector extensions: two SSE2 registers); shorter ranges pixel by pixel.
void sadCurvePortable(const cv::Mat& L, const cv::Mat& R, int u, int v, int r, int dmax,
                      uint16_t* cost) {
  constexpr int kBlock = 16;
  const int n = dmax + 1;
  if (n < kBlock) {
    for (int j = 0; j < n; ++j) cost[j] = 0;
    for (int dy = -r; dy <= r; ++dy) {
      const uint8_t* lrow = L.ptr<uint8_t>(v + dy) + u;
      const uint8_t* rrow = R.ptr<uint8_t>(v + dy) + (u - dmax);
      for (int dx = -r; dx <= r; ++dx) {
        const uint8_t l = lrow[dx];
        for (int j = 0; j < n; ++j) {
          const uint8_t x = rrow[dx + j];
          cost[j] = static_cast<uint16_t>(cost[j] + (l > x ? l - x : x - l));
        }
      }
    }
    return;
  }
  using U8x16 = uint8_t __attribute__((vector_size(16)));
  using U16x16 = uint16_t __attribute__((vector_size(32)));
  for (int j0 = 0;; j0 += kBlock) {
    const int start = std::min(j0, n - kBlock);
    U16x16 acc = {};
    for (int dy = -r; dy <= r; ++dy) {
      const uint8_t* lrow = L.ptr<uint8_t>(v + dy) + u;
      const uint8_t* rrow = R.ptr<uint8_t>(v + dy) + (u - dmax) + start;
      for (int dx = -r; dx <= r; ++dx) {
        const U8x16 l = U8x16{} + lrow[dx];
        U8x16 x;
        std::memcpy(&x, rrow + dx, sizeof x);
        const U8x16 diff = (l > x ? l : x) - (l > x ? x : l);  // |l - x|: pmaxub - pminub
        acc += __builtin_convertvector(diff, U16x16);
      }
    }
    std::memcpy(cost + start, &acc, sizeof acc);
    if (start + kBlock >= n) break;
  }
}

// Blocks of 32 disparities: |l - x| of 32 bytes in one register, widened to two 16-lane sums
// by unpacking with zero (within 128-bit halves; put in order when stored).
__attribute__((target("avx2"))) void sadCurveAvx2(const cv::Mat& L, const cv::Mat& R, int u, int v,
                                                  int r, int dmax, uint16_t* cost) {
  constexpr int kBlock = 32;
  const int n = dmax + 1;
  assert(n >= kBlock && "a curve shorter than one block takes the portable path");
  const __m256i zero = _mm256_setzero_si256();
  for (int j0 = 0;; j0 += kBlock) {
    const int start = std::min(j0, n - kBlock);
    __m256i lo = zero, hi = zero;
    for (int dy = -r; dy <= r; ++dy) {
      const uint8_t* lrow = L.ptr<uint8_t>(v + dy) + u;
      const uint8_t* rrow = R.ptr<uint8_t>(v + dy) + (u - dmax) + start;
      for (int dx = -r; dx <= r; ++dx) {
        const __m256i l = _mm256_set1_epi8(static_cast<char>(lrow[dx]));
        const __m256i x = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(rrow + dx));
        const __m256i diff = _mm256_sub_epi8(_mm256_max_epu8(l, x), _mm256_min_epu8(l, x));
        lo = _mm256_add_epi16(lo, _mm256_unpacklo_epi8(diff, zero));  // j 0-7, 16-23
        hi = _mm256_add_epi16(hi, _mm256_unpackhi_epi8(diff, zero));  // j 8-15, 24-31
      }
    }
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(cost + start),
                        _mm256_permute2x128_si256(lo, hi, 0x20));
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(cost + start + 16),
                        _mm256_permute2x128_si256(lo, hi, 0x31));
    if (start + kBlock >= n) break;
  }
}

// The lowest of cost[begin, end) (0xffff for an empty range); vectorised by the compiler.
__attribute__((target_clones("avx2", "default"))) uint16_t minCost(const uint16_t* cost, int begin,
                                                                   int end) {
  uint16_t lowest = 0xffff;
  for (int j = begin; j < end; ++j) lowest = std::min(lowest, cost[j]);
  return lowest;
}

void sadCurve(const cv::Mat& L, const cv::Mat& R, int u, int v, int r, int dmax, uint16_t* cost) {
  if (dmax + 1 >= 32 && cpuHasAvx2()) {
    sadCurveAvx2(L, R, u, v, r, dmax, cost);
  } else {
    sadCurvePortable(L, R, u, v, r, dmax, cost);
  }
}

}  // namespace

void StereoDepth::Options::declareOptions(OptionList& o) {
  o.add("window_radius_px", &window_radius_px, "px", "SAD window (2r+1)^2 at the corner's level")
      .in(1, 6);
  o.add("max_disparity_px", &max_disparity_px, "px", "largest disparity searched (level 0)")
      .in(4, kMaxDisparity);
  o.add("min_disparity_px", &min_disparity_px, "px",
        "a smaller disparity is too far to give a depth (level 0; < max_disparity_px)")
      .nonNegative();
  o.add("max_mean_abs_diff", &max_mean_abs_diff, "gray levels",
        "mean absolute difference per pixel at the best disparity at most")
      .above(0)
      .max(255);
  o.add("uniqueness_ratio", &uniqueness_ratio, "",
        "best cost <= this * second best (outside +-1 px)")
      .above(0)
      .max(1);
  o.add("subpixel", &subpixel, "refine the disparity to sub-pixel");
  o.add("max_refinement_px", &max_refinement_px, "px",
        "a refinement moving farther drops the depth (level pixels)")
      .positive();
}

Status StereoDepth::Options::validate() const {
  if (Status s = checkOptionRanges(*this, "stereo."); !s) return s;
  if (!(min_disparity_px < max_disparity_px)) {
    return makeError("stereo depth: min_disparity_px ", min_disparity_px,
                     " is not below max_disparity_px ", max_disparity_px);
  }
  return Ok{};
}

StereoDepth::StereoDepth(const Options& options) : options_(options) {
  if (Status s = options.validate(); !s) {
    std::fprintf(stderr, "evermap: StereoDepth: %s\n", s.error().message.c_str());
    std::abort();
  }
}

std::vector<float> StereoDepth::compute(const StereoCamera& camera, const ImagePyramid& left,
                                        const ImagePyramid& right,
                                        const std::vector<Keypoint>& keypoints) const {
  std::vector<float> out(keypoints.size());
  for (size_t i = 0; i < keypoints.size(); ++i) {
    out[i] = disparity(camera, left, right, keypoints[i]);
  }
  return out;
}

float StereoDepth::disparity(const StereoCamera& camera, const ImagePyramid& left,
                             const ImagePyramid& right, const Keypoint& k) const {
  constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
  if (k.level >= left.numLevels() || k.level >= right.numLevels()) return kNaN;
  const cv::Mat& L = left.level(k.level);
  const cv::Mat& R = right.level(k.level);
  const int r = options_.window_radius_px;
  const int u = static_cast<int>(std::lround(k.u)), v = static_cast<int>(std::lround(k.v));
  // One more pixel than the window for the refinement's gradient.
  if (u - r - 1 < 0 || v - r - 1 < 0 || u + r + 1 >= L.cols || v + r + 1 >= L.rows ||
      R.size() != L.size()) {
    return kNaN;
  }
  const float scale = ImagePyramid::scale(k.level);
  // Disparities [0, dmax]: the right window at u - d must stay inside the image.
  const int dmax = std::min(static_cast<int>(options_.max_disparity_px / scale), u - r - 1);
  if (dmax < 3) return kNaN;
  const int n = dmax + 1;
  alignas(32) uint16_t cost[kMaxDisparity + 16];
  sadCurve(L, R, u, v, r, dmax, cost);
  // The first lowest cost, and the lowest outside it +-1 (none when the range is that short).
  const uint16_t lowest = minCost(cost, 0, n);
  int best = 0;
  while (cost[best] != lowest) ++best;
  int second = std::numeric_limits<int>::max();
  if (best >= 2 || best + 2 < n) {
    second = std::min(minCost(cost, 0, best - 1), minCost(cost, best + 2, n));
  }
  const int area = (2 * r + 1) * (2 * r + 1);
  if (cost[best] > options_.max_mean_abs_diff * area) return kNaN;
  // Ties (repeated texture, a flat image: best == second == 0) are ambiguous too.
  if (second != std::numeric_limits<int>::max() &&
      cost[best] >= options_.uniqueness_ratio * second) {
    return kNaN;
  }
  float d = static_cast<float>(dmax - best);
  if (options_.subpixel) {
    PatchAlignmentOptions align;
    align.radius_px = r;
    align.x_only = true;
    align.max_iterations = 5;  // one unknown: converges in two or three
    align.max_shift_px = options_.max_refinement_px;
    const auto x = alignPatch(
        L, u, v, R, Eigen::Vector2f(static_cast<float>(u) - d, static_cast<float>(v)), align);
    if (!x) return kNaN;
    d = static_cast<float>(u) - x->x();
  }
  // Measured between the images -> the model's (stereo_camera.h): d = d_measured + offset
  // (+ the row slope's share at the corner's row, in level-0 pixels).
  d = d * scale + static_cast<float>(camera.disparityCorrectionPx(k.v * scale));
  if (!(d >= options_.min_disparity_px)) return kNaN;
  return d;
}

}  // namespace evermap::core
