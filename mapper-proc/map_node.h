#pragma once
// A node of the map as the mapper keeps it besides its pose (which the solver holds): when,
// on which floor and in which session it was made, and its roll/pitch factor; and what the
// mapper tracks, saved with the map.

#include <cstdint>
#include <optional>

#include <Eigen/Core>

#include "core/geometry/se3.h"
#include "core/messages/odometry_frame.h"
#include "mapper-proc/tracker.h"

namespace evermap::mapper {

// The IMU's roll and pitch at a node's keyframe (imu-proc's ATTITUDE): its partial factor.
struct NodeAttitude {
  double roll_rad = 0.0;
  double pitch_rad = 0.0;
  Eigen::Matrix2d covariance = Eigen::Matrix2d::Identity();  // rad², (roll, pitch)
};

struct MapperNode {
  int64_t id = 0;
  int64_t keyframe_utime = 0;
  int floor = 0;
  int session = 0;
  std::optional<NodeAttitude> attitude;  // when the node has a roll/pitch factor
};

// What a mapper tracks, saved with the map (map_store.h, table map_tracking) so that a
// restarted mapper can resume where the killed one was (MapperOptions::warm_restart_*).
struct TrackingState {
  int64_t utime = 0;  // message time of the pose: the tracker's newest input
  int session = 0;
  int64_t session_start_utime = -1;
  int64_t active_node = -1;  // the node tracked against
  int floor = 0;
  bool in_elevator = false;           // between a ride's start and end (no warm restart from it)
  core::UncertainPose active_T_body;  // Δ at utime, with its covariance
  // The odometry pose of the VO frame Δ is at (Tracker::odometryAtDelta), when VO tracked
  // and its sender stamps one: a restart whose first VO_DELTA is of the same epoch bridges
  // the gap with the odometry's motion (MapperOptions::warm_restart_bridge).
  std::optional<Tracker::OdometryAnchor> odometry;
  // The wheels' odometry pose (WHEEL_ODOM odom_*) at Δ's time, when their sender stamps one:
  // a restart the VO frame cannot bridge (VO's chain restarted in the gap) is bridged by the
  // wheels' motion when their epoch went on (MapperOptions::warm_restart_bridge).
  std::optional<messages::WheelOdometryPose> wheel;
};

}  // namespace evermap::mapper
