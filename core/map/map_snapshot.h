#pragma once
// The map as its store holds it (core/map/store_file.h: the schema), plain data: what the
// mapper saves, what a restarted mapper restores (Mapper::restore) and what a reader (the
// viewer, the tools) loads. The mapper-proc names of these types are aliases of these.

#include <cstdint>
#include <optional>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "core/geometry/se3.h"
#include "core/messages/odometry_frame.h"

namespace evermap::map {

// The IMU's roll and pitch at a node's keyframe (imu-proc's ATTITUDE): its partial factor.
struct NodeAttitude {
  double roll_rad = 0.0;
  double pitch_rad = 0.0;
  Eigen::Matrix2d covariance = Eigen::Matrix2d::Identity();  // rad², (roll, pitch)
};

// A node of the map as the mapper keeps it besides its pose (which the solver holds): when,
// on which floor and in which session it was made, and its roll/pitch factor.
struct MapperNode {
  int64_t id = 0;
  int64_t keyframe_utime = 0;
  int floor = 0;
  int session = 0;
  std::optional<NodeAttitude> attitude;  // when the node has a roll/pitch factor
};

enum class ConstraintKind : uint8_t { kOdometry = 0, kLoop = 1 };

// A measurement of one node's pose in another's frame (mapper-proc/constraint_set.h keeps
// them and pairs them).
struct Constraint {
  int64_t from = 0;
  int64_t to = 0;
  core::UncertainPose from_T_to;
  int64_t utime = 0;
  ConstraintKind kind = ConstraintKind::kOdometry;
  bool accepted = false;  // merged into its pair's factor
};

// The odometry pose (VO_DELTA odom_*, camera frames) of the VO frame Δ is at, and the
// covariance of that frame's own motion from its reference keyframe (its VO_DELTA covariance;
// zero for a keyframe or a chain restart): mapper-proc's Tracker::odometryAtDelta.
struct OdometryAnchor {
  messages::OdometryPose pose;
  core::Mat6 own_covariance = core::Mat6::Zero();
};

// What a mapper tracks, saved with the map (table map_tracking) so that a restarted mapper
// can resume where the killed one was (MapperOptions::warm_restart_*).
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
  std::optional<OdometryAnchor> odometry;
  // The wheels' odometry pose (WHEEL_ODOM odom_*) at Δ's time, when their sender stamps one:
  // a restart the VO frame cannot bridge (VO's chain restarted in the gap) is bridged by the
  // wheels' motion when their epoch went on (MapperOptions::warm_restart_bridge).
  std::optional<messages::WheelOdometryPose> wheel;
};

struct StoredNode {
  MapperNode node;
  core::SE3d world_T_body;
};

struct StoredEdge {
  int64_t edge_id = 0;  // increasing in the order the constraints were made
  Constraint constraint;
  int64_t folded = 0;  // > 0: a fold of this many accepted constraints (map_folds)
  int64_t folded_rejected = 0;
};

// A place a node has been seen from (mapper-proc/view_footprints.h): where a registration to
// `node` placed the robot, in the node's frame (planar: x, y and the turn about z), on the
// node's floor, in `session`.
struct Footprint {
  int64_t node = 0;
  core::SE3d node_T_view;
  int session = 0;
};

struct MapSnapshot {
  std::vector<std::pair<int, int64_t>> sessions;  // (session, start utime)
  std::vector<std::pair<int, double>> floors;     // (floor index, height m)
  std::vector<StoredNode> nodes;                  // by id
  std::vector<StoredEdge> edges;                  // by id
  std::vector<Footprint> footprints;              // in the order they were made
  std::optional<TrackingState> tracking;          // map_tracking's row, if any
  int max_saved_mapper = -1;                      // highest session_id of map_saved

  // How many constraints the edges stand for (a fold counts its members, accepted and
  // rejected): every constraint ever made, folded or not.
  int64_t constraintsRepresented() const {
    int64_t n = 0;
    for (const StoredEdge& e : edges) n += e.folded > 0 ? e.folded + e.folded_rejected : 1;
    return n;
  }
};

}  // namespace evermap::map
