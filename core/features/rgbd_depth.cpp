#include "core/features/rgbd_depth.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>

namespace evermap::core {

Status RgbdDepth::Options::validate() const {
  if (!(min_depth_m > 0.0 && min_depth_m < max_depth_m) || !std::isfinite(max_depth_m)) {
    return makeError("rgbd depth: need 0 < min_depth_m (", min_depth_m, ") < max_depth_m (",
                     max_depth_m, "), finite");
  }
  if (window_radius_px < 0 || window_radius_px > 8) {
    return makeError("rgbd depth: window_radius_px ", window_radius_px, " is not in [0, 8]");
  }
  if (!(max_relative_spread > 0.0)) {
    return makeError("rgbd depth: max_relative_spread ", max_relative_spread, " is not positive");
  }
  return Ok{};
}

RgbdDepth::RgbdDepth(const Options& options) : options_(options) {
  if (Status s = options.validate(); !s) {
    std::fprintf(stderr, "RgbdDepth: %s\n", s.error().message.c_str());
    std::abort();
  }
}

float RgbdDepth::disparity(const StereoCamera& camera, const cv::Mat& depth, double scale_m,
                           float u, float v) const {
  constexpr float kNone = std::numeric_limits<float>::quiet_NaN();
  const int r = options_.window_radius_px;
  const int cu = static_cast<int>(std::lround(u));
  const int cv = static_cast<int>(std::lround(v));
  if (cu - r < 0 || cv - r < 0 || cu + r >= depth.cols || cv + r >= depth.rows) return kNone;
  const uint16_t centre = depth.at<uint16_t>(cv, cu);
  const double z = centre * scale_m;
  if (centre == 0 || z < options_.min_depth_m || z > options_.max_depth_m) return kNone;
  uint16_t lo = centre, hi = centre;
  for (int y = cv - r; y <= cv + r; ++y) {
    const uint16_t* row = depth.ptr<uint16_t>(y);
    for (int x = cu - r; x <= cu + r; ++x) {
      if (row[x] == 0) return kNone;  // a hole next to the corner: an edge or a shadow
      lo = std::min(lo, row[x]);
      hi = std::max(hi, row[x]);
    }
  }
  if ((hi - lo) * scale_m > options_.max_relative_spread * z) return kNone;
  return static_cast<float>(camera.disparityFromDepth(z));
}

}  // namespace evermap::core
