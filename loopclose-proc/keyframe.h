#pragma once
// A keyframe as loopclose-proc keeps it: features of the rectified left image with their 3-D
// points (left camera frame) and 256-bit descriptors — what KEYFRAME (keyframe_t) carries, in
// compact arrays. Built only through fromMsg(), which validates what arrived.

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include <evermap/keyframe_t.hpp>

#include "core/bow/descriptor.h"
#include "core/common/expected.h"

namespace evermap::loopclose {

struct Keyframe {
  int64_t utime = 0;                      // microseconds: the keyframe's id
  double fx = 0, fy = 0, cx = 0, cy = 0;  // rectified left camera, pixels
  double baseline_m = 0;
  std::vector<Eigen::Vector2f> keypoints;  // pixels (u, v)
  std::vector<Eigen::Vector3f> points;     // metres, left camera frame
  std::vector<float> disparity;            // pixels
  std::vector<int8_t> level;               // pyramid level of detection
  std::vector<bow::Descriptor> descriptors;

  size_t size() const { return descriptors.size(); }
};

// Largest number of features a keyframe may claim (bounds what a malformed message costs).
inline constexpr int kMaxKeyframeFeatures = 100000;

// Checks array lengths against num_features, finiteness, positive focal lengths and baseline,
// and 32-byte descriptors; the error names the keyframe and the field. An empty keyframe
// (0 features) is valid here: it is answered with a failure reason when used.
Expected<Keyframe> fromMsg(const evermap::keyframe_t& msg);
evermap::keyframe_t toMsg(const Keyframe& keyframe);

}  // namespace evermap::loopclose
