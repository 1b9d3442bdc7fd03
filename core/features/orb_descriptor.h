#pragma once
// ORB descriptors (Rublee, Rabaud, Konolige & Bradski, "ORB: an efficient alternative to SIFT
// or SURF", ICCV 2011) at given corners of a pyramid: 256 binary intensity tests over a
// smoothed 31x31 patch, steered by the corner's orientation. The orientation is the
// intensity centroid of a disc of radius 15 (section 3.2: θ = atan2(m01, m10)), computed
// here; the tests are OpenCV's (cv::ORB::compute with the learned rBRIEF pattern, section 4),
// run on each pyramid level with the corners of that level, so the descriptors are the
// standard ones other ORB tools (vocabularies) expect.
//
// Not thread-safe (holds a cv::ORB); use one extractor per thread.

#include <array>
#include <bit>
#include <cstdint>
#include <cstring>
#include <optional>
#include <vector>

#include <opencv2/features2d.hpp>

#include "core/common/expected.h"
#include "core/features/fast_detector.h"
#include "core/features/image_pyramid.h"

namespace evermap {
class OptionList;  // core/common/option_fields.h
}  // namespace evermap

namespace evermap::core {

using OrbDescriptor = std::array<uint8_t, 32>;

// Number of differing bits, in [0, 256].
inline int hammingDistance(const OrbDescriptor& a, const OrbDescriptor& b) {
  int d = 0;
  for (int i = 0; i < 32; i += 8) {
    uint64_t x, y;
    std::memcpy(&x, a.data() + i, 8);
    std::memcpy(&y, b.data() + i, 8);
    d += std::popcount(x ^ y);
  }
  return d;
}

class OrbExtractor {
 public:
  struct Options {
    // Corners closer than this to the border of their level get no descriptor (the disc of
    // the orientation has radius 15; the test pattern reaches 21 px when rotated and reads a
    // mirrored border there, as OpenCV does).
    int border_px = 16;

    Status validate() const;
    void declareOptions(OptionList& o);
  };

  // Contract: options.validate() passes (checked, aborts otherwise).
  explicit OrbExtractor(const Options& options);

  // One entry per keypoint: its descriptor, or nullopt when it is too close to the border.
  std::vector<std::optional<OrbDescriptor>> compute(const ImagePyramid& pyramid,
                                                    const std::vector<Keypoint>& keypoints);

  // The intensity-centroid orientation (degrees, [0, 360), OpenCV's cv::KeyPoint::angle
  // convention: atan2 in image coordinates, y down) of integer pixel (u, v), which must be
  // at least 15 px from every border of `image`.
  static float orientationDeg(const cv::Mat& image, int u, int v);

 private:
  Options options_;
  cv::Ptr<cv::ORB> orb_;
};

}  // namespace evermap::core
