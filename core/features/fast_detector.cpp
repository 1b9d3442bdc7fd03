#include "core/features/fast_detector.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <numeric>
#include <sstream>

#include <opencv2/features2d.hpp>

#include "core/common/option_fields.h"

namespace evermap::core {

void FastDetector::Options::declareOptions(OptionList& o) {
  o.add("initial_threshold", &initial_threshold, "gray levels",
        "FAST threshold of the first frame (within [min_threshold, max_threshold])")
      .in(1, 254);
  o.add("min_threshold", &min_threshold, "gray levels", "the adaptive threshold at least")
      .in(1, 254);
  o.add("max_threshold", &max_threshold, "gray levels", "... and at most").in(1, 254);
  o.add("adaptive", &adaptive, "move the threshold toward the target corner count per frame");
  o.add("adaptive_gain", &adaptive_gain, "", "threshold change per corner above the target count")
      .min(0)
      .below(1);
  o.add("target_pixels_per_feature", &target_pixels_per_feature, "px",
        "target count = level-0 width * height / this")
      .min(1);
  o.add("bucketing", &bucketing, "keep the strongest corners per bucket of the image");
  o.add("bucket_width_px", &bucket_width_px, "px", "bucket width (pixels of each level)").min(1);
  o.add("bucket_height_px", &bucket_height_px, "px", "bucket height").min(1);
  o.add("max_per_bucket", &max_per_bucket, "corners", "corners kept per bucket at most").min(1);
  o.add("border_px", &border_px, "px",
        "corners closer to their level's border are dropped (>= 3: FAST's circle)")
      .min(3);
}

Status FastDetector::Options::validate() const {
  if (Status s = checkOptionRanges(*this, "fast."); !s) return s;
  if (min_threshold > max_threshold) {
    return makeError("fast detector: min_threshold ", min_threshold, " is above max_threshold ",
                     max_threshold);
  }
  if (initial_threshold < min_threshold || initial_threshold > max_threshold) {
    return makeError("fast detector: initial_threshold ", initial_threshold,
                     " is outside [min_threshold, max_threshold]");
  }
  return Ok{};
}

std::string FastDetector::Options::describe() const {
  std::ostringstream s;
  s << "threshold " << initial_threshold << " [" << min_threshold << ", " << max_threshold << "]"
    << (adaptive ? " adaptive gain " + std::to_string(adaptive_gain) : " fixed")
    << ", target 1 per " << target_pixels_per_feature << " px";
  if (bucketing) {
    s << ", buckets " << bucket_width_px << "x" << bucket_height_px << " px max " << max_per_bucket;
  }
  return s.str();
}

FastDetector::FastDetector(const Options& options)
    : options_(options), threshold_(options.initial_threshold) {
  if (Status s = options.validate(); !s) {
    std::fprintf(stderr, "evermap: FastDetector: %s\n", s.error().message.c_str());
    std::abort();
  }
}

std::vector<Keypoint> FastDetector::detect(const ImagePyramid& pyramid, int num_levels) {
  num_levels = std::min(num_levels, pyramid.numLevels());
  const int fast_threshold = threshold();
  std::vector<Keypoint> out;
  std::vector<cv::KeyPoint> corners;
  std::vector<int> order;
  std::vector<int> bucket_count;
  size_t detected = 0;
  for (int l = 0; l < num_levels; ++l) {
    const cv::Mat& image = pyramid.level(l);
    corners.clear();
    cv::FAST(image, corners, fast_threshold, /*nonmaxSuppression=*/true,
             cv::FastFeatureDetector::TYPE_9_16);
    detected += corners.size();
    const int b = options_.border_px;
    // Strongest first, so bucketing keeps the best ones and the output is ordered.
    order.resize(corners.size());
    std::iota(order.begin(), order.end(), 0);
    std::sort(order.begin(), order.end(),
              [&](int i, int j) { return corners[i].response > corners[j].response; });
    const int nbx = (image.cols + options_.bucket_width_px - 1) / options_.bucket_width_px;
    const int nby = (image.rows + options_.bucket_height_px - 1) / options_.bucket_height_px;
    bucket_count.assign(static_cast<size_t>(nbx * nby), 0);
    for (int i : order) {
      const cv::KeyPoint& k = corners[static_cast<size_t>(i)];
      const int u = static_cast<int>(k.pt.x), v = static_cast<int>(k.pt.y);
      if (u < b || v < b || u >= image.cols - b || v >= image.rows - b) continue;
      if (options_.bucketing) {
        int& count = bucket_count[static_cast<size_t>((v / options_.bucket_height_px) * nbx +
                                                      u / options_.bucket_width_px)];
        if (count >= options_.max_per_bucket) continue;
        ++count;
      }
      out.push_back({k.pt.x, k.pt.y, k.response, static_cast<int8_t>(l)});
    }
  }
  if (options_.adaptive) {
    const cv::Mat& base = pyramid.level(0);
    const double target =
        static_cast<double>(base.cols) * base.rows / options_.target_pixels_per_feature;
    threshold_ += options_.adaptive_gain * (static_cast<double>(detected) - target);
    threshold_ = std::clamp(threshold_, static_cast<double>(options_.min_threshold),
                            static_cast<double>(options_.max_threshold));
  }
  return out;
}

}  // namespace evermap::core
