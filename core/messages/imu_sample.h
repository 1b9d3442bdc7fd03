#pragma once
// One IMU sample as it goes into (and comes out of) an imu_t message: the data-set readers
// (tools/datasets) produce it, messages/convert.h turns it into imu_t and back.

#include <cstdint>

#include <Eigen/Core>

namespace evermap::messages {

struct ImuSample {
  int64_t t_ns = 0;
  Eigen::Vector3d gyro_rad_s = Eigen::Vector3d::Zero();
  Eigen::Vector3d accel_m_s2 = Eigen::Vector3d::Zero();
};

}  // namespace evermap::messages
