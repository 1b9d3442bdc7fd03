#include "tools/sim/sim_message_conversions.h"

#include "core/messages/convert.h"

namespace evermap::sim {

void writePose(const core::SE3d& pose, double translation[3], double orientation_wxyz[4]) {
  const core::Vec3& t = pose.translation();
  const Eigen::Quaterniond& q = pose.quaternion();
  for (int i = 0; i < 3; ++i) translation[i] = t[i];
  orientation_wxyz[0] = q.w();
  orientation_wxyz[1] = q.x();
  orientation_wxyz[2] = q.y();
  orientation_wxyz[3] = q.z();
}

core::SE3d readPose(const double translation[3], const double orientation_wxyz[4]) {
  const Eigen::Quaterniond q(orientation_wxyz[0], orientation_wxyz[1], orientation_wxyz[2],
                             orientation_wxyz[3]);
  return core::SE3d(q, core::Vec3(translation[0], translation[1], translation[2]));
}

void writeCovariance(const core::Mat6& covariance, double out[36]) {
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 6; ++c) out[r * 6 + c] = covariance(r, c);
  }
}

core::Mat6 readCovariance(const double in[36]) {
  core::Mat6 m;
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 6; ++c) m(r, c) = in[r * 6 + c];
  }
  return m;
}

pose_t toPoseMessage(int64_t utime, const core::SE3d& world_T_body, int floor, int session) {
  return messages::toMsg(utime, core::UncertainPose{world_T_body, core::Mat6::Zero()}, floor,
                         session);
}

core::SE3d poseOf(const pose_t& m) { return readPose(m.position, m.orientation); }
core::SE3d deltaOf(const vo_delta_t& m) { return readPose(m.translation, m.orientation); }
core::SE3d relativePoseOf(const register_result_t& m) {
  return readPose(m.translation, m.orientation);
}

keyframe_t keyframeIdentity(int64_t utime, const CameraOptions& camera) {
  keyframe_t k{};
  k.utime = utime;
  k.fx = camera.fx;
  k.fy = camera.fy;
  k.cx = camera.cx;
  k.cy = camera.cy;
  k.baseline_m = camera.baseline_m;
  k.num_features = 0;
  return k;
}

}  // namespace evermap::sim
