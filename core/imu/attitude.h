#pragma once
// Roll and pitch of the body, as imu-proc estimates them (AttitudeFilter) and publishes them
// (ATTITUDE, attitude_t), and as elevator-proc reads them to find the vertical.
//
// Roll and pitch: R = Rz(yaw) Ry(pitch) Rx(roll) (SO3d::fromRollPitchYaw), so the body's "up"
//   u = R^T e_z = (-sin(pitch), sin(roll) cos(pitch), cos(roll) cos(pitch)).

#include <cstdint>

#include <Eigen/Core>

namespace evermap::imu {

struct Attitude {
  int64_t utime = 0;
  double roll_rad = 0;
  double pitch_rad = 0;
  Eigen::Matrix2d covariance = Eigen::Matrix2d::Identity();  // over (roll, pitch), rad^2
  bool accel_trusted = false;
};

// Roll and pitch (R = Rz Ry Rx) from a gravity direction in the body frame.
Eigen::Vector2d rollPitchFromUp(const Eigen::Vector3d& up_body);
// Unit "up" in the body frame from roll and pitch (yaw does not matter).
Eigen::Vector3d upFromRollPitch(double roll_rad, double pitch_rad);

}  // namespace evermap::imu
