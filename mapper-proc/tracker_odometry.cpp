// The tracker's use of the odometry frames VO_DELTA and WHEEL_ODOM carry (docs/contracts.md;
// core/messages/odometry_frame.h): where messages were lost on the way (a lossy link, a
// partition), the motion over the hole comes from the poses of the messages on either side.
#include "mapper-proc/tracker.h"

#include <Eigen/Geometry>

#include "core/messages/odometry_frame.h"

namespace evermap::mapper {

void Tracker::anchorOdometry(const vo_delta_t& msg, const Mat6& own_covariance) {
  odometry_at_delta_.reset();
  if (msg.odom_epoch == 0) return;
  auto pose = messages::odometryPose(msg);
  if (!pose) {
    ++counts_.odometry_refused;
    return;
  }
  odometry_at_delta_ = OdometryAnchor{*pose, own_covariance};
}

std::optional<UncertainPose> Tracker::odometrySinceLastFrame(const vo_delta_t& msg) const {
  // While VO tracks Δ is at its last frame; after a silence the wheels moved Δ on, and the
  // last frame is where they took over.
  const std::optional<OdometryAnchor>& last = vo_mode_ ? odometry_at_delta_ : odometry_at_vo_lost_;
  if (!last || (!vo_mode_ && last->pose.utime != vo_lost_utime_)) return std::nullopt;
  const auto now = messages::odometryPose(msg);
  if (!now || now->epoch != last->pose.epoch) return std::nullopt;
  const auto d = messages::odometryBetween(last->pose, last->own_covariance, *now);
  if (!d) return std::nullopt;
  // A motion no robot makes in that time (a lying pose) bridges nothing.
  if (!implausibleMotion(d->mean.translation().norm(),
                         Eigen::AngleAxisd(d->mean.quaternion()).angle(), last->pose.utime,
                         now->utime)
           .empty()) {
    return std::nullopt;
  }
  return toBody(d->mean, d->covariance);
}

// WHEEL_ODOM after lost ones (a lossy link, a partition): the increment since the last one
// taken comes from the two messages' odometry poses (one epoch), so the wheels carry the hole;
// as received when nothing was lost or no pose spans the hole.
wheel_odom_t Tracker::bridgeWheelHole(const wheel_odom_t& msg) const {
  if (lastWheelUtime() < 0 || msg.prev_utime <= lastWheelUtime() || wheel_poses_.empty() ||
      wheel_poses_.back().utime != lastWheelUtime())
    return msg;
  const auto now = messages::wheelOdometryPose(msg);
  if (!now || now->epoch != wheel_poses_.back().epoch) return msg;
  const auto d = messages::wheelOdometryBetween(wheel_poses_.back(), *now);
  if (!d) return msg;
  wheel_odom_t m = msg;
  m.prev_utime = lastWheelUtime();
  m.delta_x_m = d->a_T_b.vector()[0];
  m.delta_y_m = d->a_T_b.vector()[1];
  m.delta_theta_rad = d->a_T_b.vector()[2];
  for (int k = 0; k < 9; ++k) m.covariance[k] = d->covariance(k / 3, k % 3);
  return m;
}

}  // namespace evermap::mapper
