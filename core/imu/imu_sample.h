#pragma once
// One IMU reading, the one sample type of evermap: what the data-set readers (tools/datasets)
// produce, what an imu_t message carries (core/imu/lcm_convert.h) and what the IMU filters
// take. Its values are not checked here: every consumer passes samples through a SampleGate
// (core/imu/sample_gate.h), which drops and counts non-finite, saturated and mistimed ones.

#include <cstdint>

#include <Eigen/Core>

namespace evermap::imu {

// In the body (IMU) frame.
struct ImuSample {
  int64_t utime = 0;                                     // microseconds
  Eigen::Vector3d gyro_rad_s = Eigen::Vector3d::Zero();  // angular velocity
  Eigen::Vector3d accel_m_s2 = Eigen::Vector3d::Zero();  // specific force (+g up at rest)
};

}  // namespace evermap::imu
