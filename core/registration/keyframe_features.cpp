#include "core/registration/keyframe_features.h"

#include <cmath>

namespace evermap::core {

Status KeyframeFeatures::validate() const {
  const size_t n = keypoints.size();
  if (points.size() != n || disparity.size() != n || levels.size() != n ||
      descriptors.size() != n) {
    return makeError("keyframe ", utime, ": ", n, " keypoints but ", points.size(), " points, ",
                     disparity.size(), " disparities, ", levels.size(), " levels, ",
                     descriptors.size(), " descriptors");
  }
  for (size_t i = 0; i < n; ++i) {
    if (!keypoints[i].allFinite() || !points[i].allFinite() || !std::isfinite(disparity[i])) {
      return makeError("keyframe ", utime, ": feature ", i, " is not finite");
    }
    if (!(disparity[i] > 0.0f) || !(points[i].z() > 0.0f)) {
      return makeError("keyframe ", utime, ": feature ", i, " has disparity ", disparity[i],
                       " and depth ", points[i].z(), " (both must be positive)");
    }
    if (levels[i] < 0) {
      return makeError("keyframe ", utime, ": feature ", i, " has level ",
                       static_cast<int>(levels[i]));
    }
  }
  return Ok{};
}

KeyframeFeatures makeKeyframeFeatures(const FeatureFrame& frame, OrbExtractor& orb) {
  std::vector<Keypoint> corners;
  corners.reserve(frame.features.size());
  for (const StereoFeature& f : frame.features) corners.push_back(f.keypoint);
  const auto descriptors = orb.compute(frame.left, corners);
  KeyframeFeatures k;
  k.utime = frame.utime;
  for (size_t i = 0; i < frame.features.size(); ++i) {
    if (!descriptors[i]) continue;
    const StereoFeature& f = frame.features[i];
    k.keypoints.push_back(f.uv);
    k.points.push_back(f.point.cast<float>());
    k.disparity.push_back(f.disparity);
    k.levels.push_back(f.keypoint.level);
    k.descriptors.push_back(*descriptors[i]);
  }
  return k;
}

}  // namespace evermap::core
