#pragma once
// A node of the map as the mapper keeps it besides its pose (which the solver holds): when,
// on which floor and in which session it was made, and its roll/pitch factor.

#include <cstdint>
#include <optional>

#include <Eigen/Core>

#include "core/geometry/se3.h"

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

}  // namespace evermap::mapper
