#include "tools/place-eval/epipolar_check.h"

#include <opencv2/calib3d.hpp>

namespace evermap::bow {

std::string EpipolarCheckOptions::validate() const {
  if (std::string why = matching.validate(); !why.empty()) return "matching: " + why;
  if (!(ransac_threshold_px > 0.0)) return "ransac_threshold_px must be > 0";
  if (!(confidence > 0.0 && confidence < 1.0)) return "confidence must be in (0, 1)";
  if (min_inliers < 8) return "min_inliers must be >= 8 (a fundamental matrix needs 8 points)";
  return {};
}

EpipolarCheckResult checkEpipolar(const ImageFeatures& a, const FeatureVector& direct_a,
                                  const ImageFeatures& b, const FeatureVector& direct_b,
                                  const EpipolarCheckOptions& options) {
  EpipolarCheckResult r;
  const std::vector<DescriptorMatch> matches =
      matchGuided(direct_a, a.descriptors, direct_b, b.descriptors, options.matching);
  r.matches = static_cast<int>(matches.size());
  // Fewer than 8 matches leave F undetermined up to a family: no evidence either way.
  if (matches.size() < 8) return r;
  std::vector<cv::Point2f> pa, pb;
  pa.reserve(matches.size());
  pb.reserve(matches.size());
  for (const DescriptorMatch& m : matches) {
    pa.push_back(a.keypoints[m.a].pt);
    pb.push_back(b.keypoints[m.b].pt);
  }
  std::vector<uchar> mask;
  // OpenCV's RANSAC draws from a fixed-seed generator: the same input gives the same answer.
  const cv::Mat f = cv::findFundamentalMat(pa, pb, cv::FM_RANSAC, options.ransac_threshold_px,
                                           options.confidence, mask);
  if (f.empty() || mask.size() != matches.size()) return r;
  for (uchar m : mask) r.inliers += m ? 1 : 0;
  r.accepted = r.inliers >= options.min_inliers;
  return r;
}

}  // namespace evermap::bow
