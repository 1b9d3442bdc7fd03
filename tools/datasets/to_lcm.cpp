#include "tools/datasets/to_lcm.h"

#include <cmath>
#include <cstdio>

namespace evermap::datasets {

std::string ConversionSummary::report() const {
  std::string out;
  char line[256];
  for (const auto& [channel, count] : messages) {
    std::snprintf(line, sizeof line, "  %-14s %10lld messages\n", channel.c_str(),
                  static_cast<long long>(count));
    out += line;
  }
  std::snprintf(line, sizeof line,
                "skipped: %lld image rows/frames without an image file, %lld unpaired stamps\n",
                static_cast<long long>(skipped_missing_image),
                static_cast<long long>(skipped_unpaired));
  out += line;
  out += "ground truth: " + (ground_truth.empty() ? std::string("none") : ground_truth) + "\n";
  std::snprintf(line, sizeof line, "log size: %.1f MB\n", static_cast<double>(bytes) / 1e6);
  out += line;
  return out;
}

Status EurocToLcmOptions::validate() const {
  if (!ground_truth.empty() && !std::filesystem::is_regular_file(ground_truth)) {
    return makeError(ground_truth.string(), ": ground-truth file not found");
  }
  return Ok{};
}

Status KittiToLcmOptions::validate() const {
  if (!std::isfinite(disparity_offset_px)) {
    return makeError("KITTI: disparity_offset_px ", disparity_offset_px, " is not finite");
  }
  return sequence.validate();
}

Status TumToLcmOptions::validate() const {
  if (!calibration.empty()) {
    if (auto c = tumCalibration(calibration); !c) return c.error();
  }
  if (!(depth_scale_m > 0.0) || !std::isfinite(depth_scale_m)) {
    return makeError("TUM RGB-D: depth_scale_m ", depth_scale_m, " is not positive and finite");
  }
  return sequence.validate();
}

}  // namespace evermap::datasets
