#include "core/geometry/so3.h"

#include <algorithm>
#include <cmath>

namespace evermap::core {

Vec3 vee(const Mat3& W) { return Vec3(W(2, 1), W(0, 2), W(1, 0)); }

SO3d::SO3d(const Eigen::Quaterniond& q) : q_(q.normalized()) {}

SO3d SO3d::exp(const Vec3& w) {
  const double theta2 = w.squaredNorm();
  const double theta = std::sqrt(theta2);
  const double half = 0.5 * theta;
  double imag_factor;
  double real;
  if (theta < 1e-8) {
    // Taylor expansion of sin(θ/2)/θ and cos(θ/2).
    imag_factor = 0.5 - theta2 / 48.0;
    real = 1.0 - theta2 / 8.0;
  } else {
    imag_factor = std::sin(half) / theta;
    real = std::cos(half);
  }
  Eigen::Quaterniond q(real, imag_factor * w.x(), imag_factor * w.y(), imag_factor * w.z());
  return SO3d(q);
}

SO3d SO3d::fromMatrix(const Mat3& R) { return SO3d(Eigen::Quaterniond(R)); }

SO3d SO3d::fromRollPitchYaw(double roll, double pitch, double yaw) {
  const Eigen::Quaterniond q = Eigen::AngleAxisd(yaw, Vec3::UnitZ()) *
                               Eigen::AngleAxisd(pitch, Vec3::UnitY()) *
                               Eigen::AngleAxisd(roll, Vec3::UnitX());
  return SO3d(q);
}

Vec3 SO3d::log() const {
  // Use the quaternion with w >= 0 so that the angle is in [0, pi].
  Eigen::Quaterniond q = q_;
  if (q.w() < 0.0) q.coeffs() = -q.coeffs();
  const Vec3 v = q.vec();
  const double s = v.norm();
  if (s < 1e-8) {
    // θ ≈ 2 s; 2/w * (1 - s^2/(3 w^2)) from the series of atan.
    const double w = q.w();
    return (2.0 / w - (2.0 / 3.0) * s * s / (w * w * w)) * v;
  }
  const double theta = 2.0 * std::atan2(s, q.w());
  return (theta / s) * v;
}

SO3d SO3d::operator*(const SO3d& other) const {
  Eigen::Quaterniond q = q_ * other.q_;
  // Renormalise cheaply to stop drift over long products.
  q.normalize();
  return SO3d(q, Unchecked{});
}

Vec3 SO3d::rollPitchYaw() const {
  const Mat3 R = matrix();
  const double pitch = std::asin(std::clamp(-R(2, 0), -1.0, 1.0));
  const double roll = std::atan2(R(2, 1), R(2, 2));
  const double yaw = std::atan2(R(1, 0), R(0, 0));
  return Vec3(roll, pitch, yaw);
}

Mat3 SO3d::rightJacobian(const Vec3& w) {
  const double theta2 = w.squaredNorm();
  const Mat3 W = hat(w);
  if (theta2 < 1e-10) return Mat3::Identity() - 0.5 * W + (1.0 / 6.0) * W * W;
  const double theta = std::sqrt(theta2);
  return Mat3::Identity() - ((1.0 - std::cos(theta)) / theta2) * W +
         ((theta - std::sin(theta)) / (theta2 * theta)) * W * W;
}

Mat3 SO3d::rightJacobianInverse(const Vec3& w) {
  const double theta2 = w.squaredNorm();
  const Mat3 W = hat(w);
  if (theta2 < 1e-10) return Mat3::Identity() + 0.5 * W + (1.0 / 12.0) * W * W;
  const double theta = std::sqrt(theta2);
  const double coef = 1.0 / theta2 - (1.0 + std::cos(theta)) / (2.0 * theta * std::sin(theta));
  return Mat3::Identity() + 0.5 * W + coef * W * W;
}

}  // namespace evermap::core
