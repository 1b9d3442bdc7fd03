#include "tools/sim/depth_sensor.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>

#include <opencv2/imgproc.hpp>

namespace evermap::sim {
namespace {

constexpr int kTable = 1 << 16;
constexpr int kMaxWidth = 8192;  // PinholeCamera's limit

bool valid(float z) { return std::isfinite(z) && z > 0.0f; }

// Depth edge between two neighbours: one has nothing, or they differ by more than `jump` of
// the nearer.
bool edge(float a, float b, float jump) {
  if (valid(a) != valid(b)) return true;
  if (!valid(a)) return false;
  return std::abs(a - b) > jump * std::min(a, b);
}

}  // namespace

Status DepthSensorOptions::validate() const {
  if (!(max_range_m > 0.0 && max_range_m <= 100.0))
    return makeError("max_range_m: must be in (0, 100]");
  if (!(min_range_m >= 0.0 && min_range_m < max_range_m))
    return makeError("min_range_m: need 0 <= min < max_range_m");
  if (!(noise_coefficient >= 0.0 && noise_coefficient < 0.1))
    return makeError("noise_coefficient: must be in [0, 0.1)");
  if (!(unit_m > 0.0 && unit_m <= 0.1)) return makeError("unit_m: must be in (0, 0.1]");
  if (!(max_range_m / unit_m < 65535.0)) {
    return makeError("unit_m: max_range_m / unit_m must be < 65535 (16-bit depth), got ",
                     max_range_m / unit_m);
  }
  if (!(edge_jump_fraction > 0.0 && edge_jump_fraction <= 10.0))
    return makeError("edge_jump_fraction: must be in (0, 10]");
  if (edge_hole_px < 0 || edge_hole_px > 16) return makeError("edge_hole_px: must be in [0, 16]");
  if (!(shadow_baseline_m >= 0.0 && shadow_baseline_m <= 1.0))
    return makeError("shadow_baseline_m: must be in [0, 1]");
  if (!(dropout_fraction >= 0.0 && dropout_fraction < 1.0))
    return makeError("dropout_fraction: must be in [0, 1)");
  return Ok{};
}

DepthSensor::DepthSensor(const DepthSensorOptions& options, double fx, uint64_t seed)
    : options_(options), fx_(fx), rng_(seed) {
  normal_.resize(kTable + kMaxWidth);
  for (float& n : normal_) n = static_cast<float>(rng_.normal());
  uniform_.resize(kTable + kMaxWidth);
  for (uint32_t& u : uniform_) u = static_cast<uint32_t>(rng_.bits() >> 32);
}

void DepthSensor::measure(const cv::Mat& truth, cv::Mat* out) {
  if (truth.type() != CV_32FC1 || truth.cols > kMaxWidth) {
    std::fprintf(stderr,
                 "evermap::sim: DepthSensor::measure needs a CV_32FC1 depth up to %d wide\n",
                 kMaxWidth);
    std::abort();
  }
  const int W = truth.cols, H = truth.rows;
  const auto jump = static_cast<float>(options_.edge_jump_fraction);

  // 1. Depth edges, widened.
  holes_.create(H, W, CV_8UC1);
  holes_.setTo(0);
  for (int v = 0; v < H; ++v) {
    const float* z = truth.ptr<float>(v);
    const float* below = v + 1 < H ? truth.ptr<float>(v + 1) : nullptr;
    uint8_t* h = holes_.ptr<uint8_t>(v);
    uint8_t* h_below = v + 1 < H ? holes_.ptr<uint8_t>(v + 1) : nullptr;
    for (int u = 0; u < W; ++u) {
      if (u + 1 < W && edge(z[u], z[u + 1], jump)) h[u] = h[u + 1] = 1;
      if (below && edge(z[u], below[u], jump)) h[u] = h_below[u] = 1;
    }
  }
  if (options_.edge_hole_px > 0) {
    const int k = 2 * options_.edge_hole_px + 1;
    cv::dilate(holes_, widened_, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(k, k)));
    std::swap(holes_, widened_);
  }
  // 2. The projector's shadow: left of a near object's left edge (far on the left, near on
  // the right), the far pixels within f b (1/z_near - 1/z_far) of the edge.
  if (options_.shadow_baseline_m > 0.0) {
    const double fb = fx_ * options_.shadow_baseline_m;
    for (int v = 0; v < H; ++v) {
      const float* z = truth.ptr<float>(v);
      uint8_t* h = holes_.ptr<uint8_t>(v);
      for (int u = 1; u < W; ++u) {
        const float near = z[u];
        if (!valid(near)) continue;
        const float far = valid(z[u - 1]) ? z[u - 1] : std::numeric_limits<float>::infinity();
        if (!(far > near * (1.0f + jump))) continue;
        const double width = fb * (1.0 / near - (std::isfinite(far) ? 1.0 / far : 0.0));
        const int last = std::max(0, u - static_cast<int>(std::ceil(width)));
        for (int s = u - 1; s >= last && !(valid(z[s]) && z[s] <= near * (1.0f + jump)); --s)
          h[s] = 1;
      }
    }
  }

  // 3-6. Dropout, noise, range, quantisation.
  out->create(H, W, CV_16UC1);
  const auto drop_below = static_cast<uint64_t>(options_.dropout_fraction * 4294967296.0);
  const double inv_unit = 1.0 / options_.unit_m;
  for (int v = 0; v < H; ++v) {
    const float* z = truth.ptr<float>(v);
    const uint8_t* h = holes_.ptr<uint8_t>(v);
    uint16_t* o = out->ptr<uint16_t>(v);
    const float* n = normal_.data() + rng_.index(kTable);
    const uint32_t* r = uniform_.data() + rng_.index(kTable);
    for (int u = 0; u < W; ++u) {
      o[u] = 0;
      if (h[u] || !valid(z[u]) || r[u] < drop_below) continue;
      const double zt = z[u];
      const double zm = zt + sigma(zt) * n[u];
      if (zm < options_.min_range_m || zm > options_.max_range_m) continue;
      o[u] = static_cast<uint16_t>(std::clamp(std::lround(zm * inv_unit), 1L, 65535L));
    }
  }
}

}  // namespace evermap::sim
