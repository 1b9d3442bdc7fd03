#include "core/features/rgbd_depth.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>

#include "core/common/option_fields.h"

namespace evermap::core {

void RgbdDepth::Options::declareOptions(OptionList& o) {
  o.add("min_depth_m", &min_depth_m, "m", "nearer depths are refused (the sensor's near limit)")
      .positive();
  o.add("max_depth_m", &max_depth_m, "m", "farther depths are refused (> min_depth_m)").positive();
  o.add("window_radius_px", &window_radius_px, "px",
        "level-0 pixels around the corner checked for holes and edges")
      .in(0, 8);
  o.add("max_relative_spread", &max_relative_spread, "",
        "largest depth spread of the window, as a fraction of the depth")
      .positive();
}

Status RgbdDepth::Options::validate() const {
  if (Status s = checkOptionRanges(*this, "rgbd."); !s) return s;
  if (!(min_depth_m < max_depth_m)) {
    return makeError("rgbd depth: min_depth_m ", min_depth_m, " is not below max_depth_m ",
                     max_depth_m);
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
