#include "core/features/fast_detector.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <numeric>
#include <sstream>

#include <opencv2/features2d.hpp>

namespace evermap::core {

Status FastDetector::Options::validate() const {
  if (min_threshold < 1 || max_threshold > 254 || min_threshold > max_threshold) {
    return makeError("fast detector: threshold range [", min_threshold, ", ", max_threshold,
                     "] is not within [1, 254]");
  }
  if (initial_threshold < min_threshold || initial_threshold > max_threshold) {
    return makeError("fast detector: initial_threshold ", initial_threshold,
                     " is outside [min_threshold, max_threshold]");
  }
  if (!(adaptive_gain >= 0.0 && adaptive_gain < 1.0)) {
    return makeError("fast detector: adaptive_gain ", adaptive_gain, " is not in [0, 1)");
  }
  if (target_pixels_per_feature < 1) {
    return makeError("fast detector: target_pixels_per_feature ", target_pixels_per_feature,
                     " must be positive");
  }
  if (bucket_width_px < 1 || bucket_height_px < 1 || max_per_bucket < 1) {
    return makeError("fast detector: bucket ", bucket_width_px, "x", bucket_height_px, " px, ",
                     max_per_bucket, " per bucket: all must be positive");
  }
  if (border_px < 3) {
    return makeError("fast detector: border_px ", border_px, " must be >= 3 (FAST's circle)");
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
