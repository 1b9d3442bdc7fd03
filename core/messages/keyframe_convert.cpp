#include "core/messages/keyframe_convert.h"

#include <algorithm>
#include <cmath>
#include <cstring>

namespace evermap::messages {

evermap::keyframe_t toMsg(const core::StereoCamera& camera,
                          const core::KeyframeFeatures& features) {
  // The camera's disparity offset (right cx - left cx) does not travel: the message carries
  // disparities and points already corrected by it (StereoDepth adds it when it measures), and
  // a receiver never matches left against right again, so its camera is the offset-free model
  // with the same depths (fromMsg below: offset 0). keyframe_t stays as it is.
  evermap::keyframe_t msg;
  msg.utime = features.utime;
  msg.fx = camera.fx();
  msg.fy = camera.fy();
  msg.cx = camera.cx();
  msg.cy = camera.cy();
  msg.baseline_m = camera.baselineM();
  const size_t n = features.size();
  msg.num_features = static_cast<int32_t>(n);
  msg.keypoints.resize(n);
  msg.points.resize(n);
  msg.disparity.resize(n);
  msg.level.resize(n);
  msg.descriptors.resize(n);
  for (size_t i = 0; i < n; ++i) {
    msg.keypoints[i] = {features.keypoints[i].x(), features.keypoints[i].y()};
    msg.points[i] = {features.points[i].x(), features.points[i].y(), features.points[i].z()};
    msg.disparity[i] = features.disparity[i];
    msg.level[i] = features.levels[i];
    msg.descriptors[i].assign(features.descriptors[i].begin(), features.descriptors[i].end());
  }
  return msg;
}

Expected<KeyframeMsgContents> fromMsg(const evermap::keyframe_t& msg) {
  const std::string who = "keyframe_t " + std::to_string(msg.utime);
  if (msg.num_features < 0 || msg.num_features > kMaxKeyframeFeatures) {
    return makeError(who, ": num_features ", msg.num_features, " is outside [0, ",
                     kMaxKeyframeFeatures, "]");
  }
  const auto n = static_cast<size_t>(msg.num_features);
  if (msg.keypoints.size() != n || msg.points.size() != n || msg.disparity.size() != n ||
      msg.level.size() != n || msg.descriptors.size() != n) {
    return makeError(who, ": array lengths differ from num_features ", n);
  }
  core::KeyframeFeatures f;
  f.utime = msg.utime;
  f.keypoints.resize(n);
  f.points.resize(n);
  f.disparity = msg.disparity;
  f.levels = msg.level;
  f.descriptors.resize(n);
  double max_u = 0.0, max_v = 0.0;
  for (size_t i = 0; i < n; ++i) {
    if (msg.keypoints[i].size() != 2 || msg.points[i].size() != 3 ||
        msg.descriptors[i].size() != 32) {
      return makeError(who, ": feature ", i, " has malformed inner arrays");
    }
    f.keypoints[i] = Eigen::Vector2f(msg.keypoints[i][0], msg.keypoints[i][1]);
    f.points[i] = Eigen::Vector3f(msg.points[i][0], msg.points[i][1], msg.points[i][2]);
    std::copy(msg.descriptors[i].begin(), msg.descriptors[i].end(), f.descriptors[i].begin());
    if (f.keypoints[i].allFinite()) {
      max_u = std::max(max_u, static_cast<double>(f.keypoints[i].x()));
      max_v = std::max(max_v, static_cast<double>(f.keypoints[i].y()));
    }
  }
  if (Status s = f.validate(); !s) return makeError("keyframe_t: ", s.error().message);
  for (size_t i = 0; i < n; ++i) {
    if (f.keypoints[i].x() < 0.0f || f.keypoints[i].y() < 0.0f) {
      return makeError(who, ": keypoint ", i, " has negative pixel coordinates");
    }
  }
  if (!(std::isfinite(msg.cx) && std::isfinite(msg.cy) && msg.cx > 0.0 && msg.cy > 0.0 &&
        msg.cx < 1e6 && msg.cy < 1e6 && max_u < 1e6 && max_v < 1e6)) {
    return makeError(who, ": principal point (", msg.cx, ", ", msg.cy, ") is not valid");
  }
  const int width = static_cast<int>(std::ceil(std::max(2.0 * msg.cx, max_u + 1.0)));
  const int height = static_cast<int>(std::ceil(std::max(2.0 * msg.cy, max_v + 1.0)));
  auto camera =
      core::StereoCamera::create(msg.fx, msg.fy, msg.cx, msg.cy, msg.baseline_m, width, height);
  if (!camera) return makeError(who, ": ", camera.error().message);
  return KeyframeMsgContents{*camera, std::move(f)};
}

}  // namespace evermap::messages
