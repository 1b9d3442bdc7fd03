#pragma once
// Chains visual odometry deltas into a trajectory: the pose of the (rectified left) camera in
// the frame of the first reference keyframe, world_T_cur = world_T_ref * ref_T_cur, the
// reference moving on at every keyframe change. For evaluation and the offline runner; the
// mapper does the same with uncertainty and with other sensors.
//
// Where VO fails, a frame has no pose. When the reference is replaced after a failure, the
// chain is broken: the new reference is placed at the last known pose (a "break", counted),
// which is where the mapper would use wheel odometry instead.

#include <cstdint>
#include <optional>

#include <evermap/vo_delta_t.hpp>

#include "core/geometry/se3.h"

namespace evermap::vo {

class VoTrajectory {
 public:
  // Feeds the next delta (in time order); returns world_T_cur when the frame has a pose
  // (STATUS_OK, or STATUS_NO_DATA for a first reference).
  std::optional<core::SE3d> add(const evermap::vo_delta_t& delta);

  int breaks() const { return breaks_; }
  int64_t posed() const { return posed_; }

 private:
  bool started_ = false;
  int64_t ref_utime_ = 0;
  core::SE3d world_T_ref_;
  core::SE3d world_T_last_;
  int breaks_ = 0;
  int64_t posed_ = 0;
};

}  // namespace evermap::vo
