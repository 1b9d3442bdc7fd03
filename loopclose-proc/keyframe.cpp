#include "loopclose-proc/keyframe.h"

#include <cmath>
#include <string>

namespace evermap::loopclose {

Expected<Keyframe> fromMsg(const evermap::keyframe_t& m) {
  const std::string what = "keyframe " + std::to_string(m.utime);
  const int n = m.num_features;
  if (n < 0 || n > kMaxKeyframeFeatures) {
    return makeError(what, ": num_features ", n, " is outside [0, ", kMaxKeyframeFeatures, "]");
  }
  const auto un = static_cast<size_t>(n);
  if (m.keypoints.size() != un || m.points.size() != un || m.disparity.size() != un ||
      m.level.size() != un || m.descriptors.size() != un) {
    return makeError(what, ": array lengths disagree with num_features = ", n);
  }
  for (double v : {m.fx, m.fy, m.cx, m.cy, m.baseline_m}) {
    if (!std::isfinite(v)) return makeError(what, ": non-finite camera parameter");
  }
  if (!(m.fx > 0 && m.fy > 0 && m.baseline_m > 0)) {
    return makeError(what, ": focal lengths and baseline must be > 0");
  }
  Keyframe k;
  k.utime = m.utime;
  k.fx = m.fx;
  k.fy = m.fy;
  k.cx = m.cx;
  k.cy = m.cy;
  k.baseline_m = m.baseline_m;
  k.keypoints.reserve(un);
  k.points.reserve(un);
  k.descriptors.reserve(un);
  for (size_t i = 0; i < un; ++i) {
    if (m.keypoints[i].size() != 2 || m.points[i].size() != 3 || m.descriptors[i].size() != 32) {
      return makeError(what, ": feature ", i, " has arrays of the wrong size");
    }
    const Eigen::Vector2f uv(m.keypoints[i][0], m.keypoints[i][1]);
    const Eigen::Vector3f p(m.points[i][0], m.points[i][1], m.points[i][2]);
    if (!uv.allFinite() || !p.allFinite() || !std::isfinite(m.disparity[i])) {
      return makeError(what, ": feature ", i, " has a non-finite value");
    }
    k.keypoints.push_back(uv);
    k.points.push_back(p);
    k.descriptors.push_back(bow::descriptorFromBytes(m.descriptors[i].data()));
  }
  k.disparity = m.disparity;
  k.level = m.level;
  return k;
}

evermap::keyframe_t toMsg(const Keyframe& k) {
  evermap::keyframe_t m;
  m.utime = k.utime;
  m.fx = k.fx;
  m.fy = k.fy;
  m.cx = k.cx;
  m.cy = k.cy;
  m.baseline_m = k.baseline_m;
  m.num_features = static_cast<int32_t>(k.size());
  for (size_t i = 0; i < k.size(); ++i) {
    m.keypoints.push_back({k.keypoints[i].x(), k.keypoints[i].y()});
    m.points.push_back({k.points[i].x(), k.points[i].y(), k.points[i].z()});
    m.descriptors.emplace_back(k.descriptors[i].bytes.begin(), k.descriptors[i].bytes.end());
  }
  m.disparity = k.disparity;
  m.level = k.level;
  return m;
}

}  // namespace evermap::loopclose
