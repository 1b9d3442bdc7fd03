#pragma once
// SE(3) as a small value type, and the compounding operators of Smith, Self & Cheeseman.
//
// `a_T_b` maps points in frame b to frame a: p_a = a_T_b * p_b.
// Tangent vectors are ordered (υ, ω): translation first, as Sophus; covariances follow.
// Perturbations are on the right: T ⊞ δ = T * exp(δ), so a covariance of T lives in the
// tangent space at T, expressed in T's own (child) frame.
// Formulas: Barfoot (2017) sections 7.1.3-7.1.5; Sola et al. (2018) appendix D.

#include <Eigen/Core>

#include "core/geometry/so3.h"

namespace evermap::core {

using Vec6 = Eigen::Matrix<double, 6, 1>;
using Mat6 = Eigen::Matrix<double, 6, 6>;
using Mat4 = Eigen::Matrix4d;

class SE3d {
 public:
  SE3d() : t_(Vec3::Zero()) {}
  SE3d(const SO3d& R, const Vec3& t) : R_(R), t_(t) {}
  SE3d(const Eigen::Quaterniond& q, const Vec3& t) : R_(q), t_(t) {}

  static SE3d identity() { return SE3d(); }
  // exp of ξ = (υ, ω): rotation exp(ω), translation V(ω) υ with V = Jl(ω).
  static SE3d exp(const Vec6& xi);
  // From a 4x4 homogeneous matrix; the rotation block is projected onto SO(3).
  static SE3d fromMatrix(const Mat4& T);

  Vec6 log() const;
  SE3d inverse() const;
  SE3d operator*(const SE3d& b) const { return SE3d(R_ * b.R_, R_ * b.t_ + t_); }
  Vec3 operator*(const Vec3& p) const { return R_ * p + t_; }
  Mat4 matrix() const;

  const SO3d& so3() const { return R_; }
  const Vec3& translation() const { return t_; }
  Mat3 rotationMatrix() const { return R_.matrix(); }
  const Eigen::Quaterniond& quaternion() const { return R_.quaternion(); }

  // Ad(T) with exp(Ad(T) ξ) = T exp(ξ) T^-1. With (υ, ω) order: [[R, t^ R], [0, R]].
  Mat6 adjoint() const;

  // SE(3) Jacobians: exp(ξ + d) ≈ exp(ξ) exp(Jr(ξ) d). Barfoot eq. 7.83-7.85 (with -ξ).
  static Mat6 rightJacobian(const Vec6& xi);
  static Mat6 rightJacobianInverse(const Vec6& xi);

 private:
  SO3d R_;
  Vec3 t_;
};

// ---- Compounding (Smith, Self & Cheeseman 1990, in Lie-group form) ----
//
// ⊕ : z13 = z12 ⊕ z23 = z12 * z23                              (paper eq. 6)
// ⊖ : ⊖z12 = z12^-1
// Jacobians are with respect to right perturbations of each argument:
//   d(z12 ⊕ z23)/dz12 = Ad(z23^-1),   d(z12 ⊕ z23)/dz23 = I,   d(⊖z)/dz = -Ad(z).

// z12 ⊕ z23, with optional Jacobians.
SE3d compose(const SE3d& z12, const SE3d& z23, Mat6* J_z12 = nullptr, Mat6* J_z23 = nullptr);
// ⊖z, with optional Jacobian.
SE3d inverse(const SE3d& z, Mat6* J_z = nullptr);
// a^-1 * b (the relative pose f(a, b) of the paper: b = a ⊕ f(a, b)), with optional Jacobians.
SE3d between(const SE3d& a, const SE3d& b, Mat6* J_a = nullptr, Mat6* J_b = nullptr);

// A pose with its 6x6 covariance in the right tangent space.
struct UncertainPose {
  SE3d mean;
  Mat6 covariance = Mat6::Zero();
};

// Paper eq. (6)-(7): first-order compounding of independent uncertain transformations,
// Σ13 = J1 Σ12 J1ᵀ + J2 Σ23 J2ᵀ.
UncertainPose compound(const UncertainPose& z12, const UncertainPose& z23);
// The uncertain inverse: Σ' = Ad(z) Σ Ad(z)ᵀ.
UncertainPose invert(const UncertainPose& z);

// Chordal distance between rotations and translation distance, for tests and evaluation.
double rotationAngle(const SO3d& R);  // radians, in [0, pi]

}  // namespace evermap::core
