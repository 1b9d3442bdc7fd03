#pragma once
// FAST corners on every level of a Gaussian pyramid, with the two controls of FOVIS (Huang et
// al., "Visual odometry and mapping for autonomous flight using an RGB-D camera", ISRR 2011,
// section 3.2):
//  - an adaptive threshold: after each frame the threshold moves in proportion to the excess
//    of detected corners over a target count, so the count stays near the target as the
//    lighting and texture change (a dark or blank view lowers it to min_threshold);
//  - grid bucketing: per bucket of the image, only the strongest corners are kept, which
//    spreads the features over the view and bounds their number.
// The segment test itself is cv::FAST (Rosten & Drummond, ECCV 2006; 9 of 16 contiguous
// pixels, non-maximum suppression on the score).
//
// Not thread-safe: the threshold is state carried from frame to frame.

#include <cstdint>
#include <string>
#include <vector>

#include "core/common/expected.h"
#include "core/features/image_pyramid.h"

namespace evermap {
class OptionList;  // core/common/option_fields.h
}  // namespace evermap

namespace evermap::core {

// A corner. (u, v) are pixels of its pyramid level; level-0 pixels are (u, v) * 2^level.
struct Keypoint {
  float u = 0.0f;
  float v = 0.0f;
  float score = 0.0f;  // FAST score (the largest threshold at which it is still a corner)
  int8_t level = 0;
};

class FastDetector {
 public:
  struct Options {
    // Initial FAST threshold (intensity difference, gray levels) and its range.
    int initial_threshold = 10;
    int min_threshold = 6;
    int max_threshold = 70;
    // Adapt the threshold after each frame: t += adaptive_gain * (count - target), where count
    // is the number of corners before bucketing over all levels.
    bool adaptive = true;
    double adaptive_gain = 0.002;
    // The target count is width * height / target_pixels_per_feature of level 0.
    int target_pixels_per_feature = 250;
    // Bucketing (pixels of each level): at most max_per_bucket corners per bucket.
    bool bucketing = true;
    int bucket_width_px = 50;
    int bucket_height_px = 50;
    int max_per_bucket = 10;
    // Corners closer than this to the border of their level are dropped (room for the
    // descriptor patch around them).
    int border_px = 6;

    Status validate() const;
    std::string describe() const;
    void declareOptions(OptionList& o);
  };

  // Contract: options.validate() passes (checked, aborts otherwise).
  explicit FastDetector(const Options& options);

  // Corners on levels [0, num_levels) of `pyramid` (num_levels <= pyramid.numLevels()),
  // strongest first within each level, levels in increasing order. Updates the threshold.
  std::vector<Keypoint> detect(const ImagePyramid& pyramid, int num_levels);

  int threshold() const { return static_cast<int>(threshold_ + 0.5); }
  const Options& options() const { return options_; }

 private:
  Options options_;
  double threshold_;
};

}  // namespace evermap::core
