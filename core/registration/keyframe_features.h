#pragma once
// The features of a keyframe as the map keeps them and loop closure registers them: per
// feature its level-0 pixel in the rectified left image, its 3-D point in the left camera
// frame, its disparity, the pyramid level it was found on and its ORB descriptor. The fields
// are those of the LCM message keyframe_t (core/messages/keyframe_convert.h converts).

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "core/common/expected.h"
#include "core/features/orb_descriptor.h"
#include "core/features/stereo_features.h"

namespace evermap::core {

struct KeyframeFeatures {
  int64_t utime = 0;
  std::vector<Eigen::Vector2f> keypoints;  // level-0 pixels (u, v)
  std::vector<Eigen::Vector3f> points;     // left camera frame, metres
  std::vector<float> disparity;            // level-0 pixels, > 0; the model's (offset applied)
  std::vector<int8_t> levels;              // pyramid level of detection, >= 0
  std::vector<OrbDescriptor> descriptors;

  size_t size() const { return keypoints.size(); }
  // Equal lengths, finite values, positive disparity and depth, non-negative level.
  Status validate() const;
};

// The features of `frame` that get an ORB descriptor (those far enough from the border).
KeyframeFeatures makeKeyframeFeatures(const FeatureFrame& frame, OrbExtractor& orb);

}  // namespace evermap::core
