#include "core/imu/attitude.h"

#include <algorithm>
#include <cmath>

namespace evermap::imu {

Eigen::Vector2d rollPitchFromUp(const Eigen::Vector3d& up_body) {
  const Eigen::Vector3d u = up_body.normalized();
  return {std::atan2(u.y(), u.z()), -std::asin(std::clamp(u.x(), -1.0, 1.0))};
}

Eigen::Vector3d upFromRollPitch(double roll_rad, double pitch_rad) {
  return {-std::sin(pitch_rad), std::sin(roll_rad) * std::cos(pitch_rad),
          std::cos(roll_rad) * std::cos(pitch_rad)};
}

}  // namespace evermap::imu
