#include "tools/vo-run/vo_trajectory.h"

#include "core/messages/pose_fields.h"

namespace evermap::vo {

std::optional<core::SE3d> VoTrajectory::add(const evermap::vo_delta_t& d) {
  const bool ok = d.status == evermap::vo_delta_t::STATUS_OK;
  const bool first = d.status == evermap::vo_delta_t::STATUS_NO_DATA && d.keyframe_changed;
  std::optional<core::SE3d> pose;
  if (first) {
    if (started_) ++breaks_;  // odometry restarted: continue from the last pose
    world_T_ref_ = started_ ? world_T_last_ : core::SE3d();
    started_ = true;
    ref_utime_ = d.utime;
    pose = world_T_ref_;
  } else if (ok && started_ && d.ref_utime == ref_utime_) {
    // A malformed motion (not finite, not a unit quaternion) gives this frame no pose.
    if (const auto ref_T_cur =
            messages::poseFromMessage(d.translation, d.orientation, "VO_DELTA")) {
      pose = world_T_ref_ * *ref_T_cur;
      if (d.keyframe_changed) {
        world_T_ref_ = *pose;
        ref_utime_ = d.utime;
      }
    }
  } else if (d.keyframe_changed && started_) {
    // A new reference without a motion to it: bridge the gap with the last pose.
    ++breaks_;
    world_T_ref_ = world_T_last_;
    ref_utime_ = d.utime;
  }
  if (pose) {
    world_T_last_ = *pose;
    ++posed_;
  }
  return pose;
}

}  // namespace evermap::vo
