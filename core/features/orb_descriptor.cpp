#include "core/features/orb_descriptor.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "core/common/option_fields.h"

namespace evermap::core {

namespace {
constexpr int kCentroidRadius = 15;  // ORB's 31x31 patch
}  // namespace

void OrbExtractor::Options::declareOptions(OptionList& o) {
  o.add("border_px", &border_px, "px",
        "corners closer to their level's border get no descriptor (>= 16: the orientation disc)")
      .min(kCentroidRadius + 1);
}

Status OrbExtractor::Options::validate() const { return checkOptionRanges(*this, "orb."); }

OrbExtractor::OrbExtractor(const Options& options) : options_(options) {
  if (Status s = options.validate(); !s) {
    std::fprintf(stderr, "evermap: OrbExtractor: %s\n", s.error().message.c_str());
    std::abort();
  }
  // One level: the pyramid is ours. edgeThreshold only filters corners near the border (we
  // filter first); patchSize 31 is the size the rBRIEF pattern was learned for.
  orb_ = cv::ORB::create(/*nfeatures=*/1, /*scaleFactor=*/2.0f, /*nlevels=*/1,
                         /*edgeThreshold=*/options.border_px, /*firstLevel=*/0, /*WTA_K=*/2,
                         cv::ORB::HARRIS_SCORE, /*patchSize=*/31);
}

float OrbExtractor::orientationDeg(const cv::Mat& image, int u, int v) {
  // Moments of the disc: m10 = Σ x I(x, y), m01 = Σ y I(x, y) (Rublee et al. eq. 1-2).
  double m10 = 0.0, m01 = 0.0;
  for (int dy = -kCentroidRadius; dy <= kCentroidRadius; ++dy) {
    const int half = static_cast<int>(std::sqrt(kCentroidRadius * kCentroidRadius - dy * dy));
    const uint8_t* row = image.ptr<uint8_t>(v + dy) + u;
    int row_sum = 0;
    for (int dx = -half; dx <= half; ++dx) {
      m10 += dx * row[dx];
      row_sum += row[dx];
    }
    m01 += static_cast<double>(dy) * row_sum;
  }
  double deg = std::atan2(m01, m10) * 180.0 / M_PI;
  if (deg < 0.0) deg += 360.0;
  return static_cast<float>(deg);
}

std::vector<std::optional<OrbDescriptor>> OrbExtractor::compute(
    const ImagePyramid& pyramid, const std::vector<Keypoint>& keypoints) {
  std::vector<std::optional<OrbDescriptor>> out(keypoints.size());
  const int b = options_.border_px;
  std::vector<cv::KeyPoint> level_keypoints;
  cv::Mat descriptors;
  for (int l = 0; l < pyramid.numLevels(); ++l) {
    const cv::Mat& image = pyramid.level(l);
    level_keypoints.clear();
    for (size_t i = 0; i < keypoints.size(); ++i) {
      const Keypoint& k = keypoints[i];
      if (k.level != l) continue;
      const int u = static_cast<int>(std::lround(k.u)), v = static_cast<int>(std::lround(k.v));
      if (u < b || v < b || u >= image.cols - b || v >= image.rows - b) continue;
      cv::KeyPoint kp(static_cast<float>(u), static_cast<float>(v), 31.0f,
                      orientationDeg(image, u, v), k.score, /*octave=*/0,
                      /*class_id=*/static_cast<int>(i));
      level_keypoints.push_back(kp);
    }
    if (level_keypoints.empty()) continue;
    orb_->compute(image, level_keypoints, descriptors);
    // cv::ORB may drop or reorder corners: class_id names the input each row belongs to.
    for (size_t j = 0; j < level_keypoints.size(); ++j) {
      const int i = level_keypoints[j].class_id;
      if (i < 0 || static_cast<size_t>(i) >= keypoints.size()) continue;
      OrbDescriptor d;
      std::memcpy(d.data(), descriptors.ptr<uint8_t>(static_cast<int>(j)), d.size());
      out[static_cast<size_t>(i)] = d;
    }
  }
  return out;
}

}  // namespace evermap::core
