#pragma once
// SO(3) as a small value type.
//
// Conventions (fixed for the whole project, pinned by tests/geometry_test.cpp):
//  - Quaternions are Hamilton, stored by Eigen; where we serialise we write (w, x, y, z).
//  - `a_R_b` maps vectors in frame b to frame a.
//  - Perturbations are on the right: R ⊞ δ = R * exp(δ).
// Formulas: Barfoot, "State Estimation for Robotics" (2017), sections 7.1.2-7.1.5;
// Sola et al., "A micro Lie theory for state estimation in robotics" (2018), appendix A.

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace evermap::core {

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;

// The skew-symmetric matrix with hat(a) * b == a.cross(b).
inline Mat3 hat(const Vec3& w) {
  Mat3 W;
  W << 0.0, -w.z(), w.y(), w.z(), 0.0, -w.x(), -w.y(), w.x(), 0.0;
  return W;
}
// Inverse of hat for a skew-symmetric matrix.
Vec3 vee(const Mat3& W);

class SO3d {
 public:
  SO3d() : q_(Eigen::Quaterniond::Identity()) {}
  // Normalises q; q and -q are the same rotation.
  explicit SO3d(const Eigen::Quaterniond& q);

  static SO3d identity() { return SO3d(); }
  // Rodrigues: exp of the rotation vector w (axis * angle), angle in radians.
  static SO3d exp(const Vec3& w);
  // Projects an almost-orthonormal matrix onto SO(3) (via its quaternion).
  static SO3d fromMatrix(const Mat3& R);
  // Aerospace convention: R = Rz(yaw) * Ry(pitch) * Rx(roll).
  static SO3d fromRollPitchYaw(double roll, double pitch, double yaw);

  // The rotation vector with angle in [0, pi].
  Vec3 log() const;
  SO3d inverse() const { return SO3d(q_.conjugate(), Unchecked{}); }
  SO3d operator*(const SO3d& other) const;
  Vec3 operator*(const Vec3& v) const { return q_ * v; }
  Mat3 matrix() const { return q_.toRotationMatrix(); }
  const Eigen::Quaterniond& quaternion() const { return q_; }
  // Ad(R) = R for SO(3): exp(Ad(R) w) = R exp(w) R^-1.
  Mat3 adjoint() const { return matrix(); }
  // Inverse of fromRollPitchYaw; (roll, pitch, yaw).
  Vec3 rollPitchYaw() const;

  // Right Jacobian: exp(w + d) ≈ exp(w) exp(Jr(w) d) (Barfoot eq. 7.77, with -w).
  static Mat3 rightJacobian(const Vec3& w);
  static Mat3 rightJacobianInverse(const Vec3& w);
  // Left Jacobian: exp(w + d) ≈ exp(Jl(w) d) exp(w). Jl(w) = Jr(-w).
  static Mat3 leftJacobian(const Vec3& w) { return rightJacobian(-w); }
  static Mat3 leftJacobianInverse(const Vec3& w) { return rightJacobianInverse(-w); }

 private:
  struct Unchecked {};
  SO3d(const Eigen::Quaterniond& q, Unchecked) : q_(q) {}
  Eigen::Quaterniond q_;
};

}  // namespace evermap::core
