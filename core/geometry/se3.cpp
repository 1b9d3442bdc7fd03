#include "core/geometry/se3.h"

#include <cmath>

namespace evermap::core {
namespace {

// Q(ρ, θ) of Barfoot eq. 7.86 (left Jacobian off-diagonal block).
Mat3 leftQ(const Vec3& rho, const Vec3& phi) {
  const Mat3 P = hat(phi);
  const Mat3 R = hat(rho);
  const double th2 = phi.squaredNorm();
  if (th2 < 1e-10) {
    return 0.5 * R + (1.0 / 6.0) * (P * R + R * P + P * R * P);
  }
  const double th = std::sqrt(th2);
  const double s = std::sin(th);
  const double c = std::cos(th);
  const double a = (th - s) / (th2 * th);
  const double b = (th2 + 2.0 * c - 2.0) / (2.0 * th2 * th2);
  const double d = (2.0 * th - 3.0 * s + th * c) / (2.0 * th2 * th2 * th);
  return 0.5 * R + a * (P * R + R * P + P * R * P) + b * (P * P * R + R * P * P - 3.0 * P * R * P) +
         d * (P * R * P * P + P * P * R * P);
}

// [[A, B], [0, A]]: the form of SE(3)'s left Jacobian and its inverse, (υ, ω) order.
Mat6 blockUpperTriangular(const Mat3& A, const Mat3& B) {
  Mat6 J = Mat6::Zero();
  J.topLeftCorner<3, 3>() = A;
  J.bottomRightCorner<3, 3>() = A;
  J.topRightCorner<3, 3>() = B;
  return J;
}

// Left Jacobian of SE(3), (υ, ω) order.
Mat6 leftJacobianSE3(const Vec6& xi) {
  const Vec3 rho = xi.head<3>();
  const Vec3 phi = xi.tail<3>();
  return blockUpperTriangular(SO3d::leftJacobian(phi), leftQ(rho, phi));
}

Mat6 leftJacobianInverseSE3(const Vec6& xi) {
  const Vec3 rho = xi.head<3>();
  const Vec3 phi = xi.tail<3>();
  const Mat3 Jli = SO3d::leftJacobianInverse(phi);
  return blockUpperTriangular(Jli, -Jli * leftQ(rho, phi) * Jli);
}

}  // namespace

SE3d SE3d::exp(const Vec6& xi) {
  const Vec3 phi = xi.tail<3>();
  return SE3d(SO3d::exp(phi), SO3d::leftJacobian(phi) * xi.head<3>());
}

SE3d SE3d::fromMatrix(const Mat4& T) {
  return SE3d(SO3d::fromMatrix(T.topLeftCorner<3, 3>()), T.topRightCorner<3, 1>());
}

Vec6 SE3d::log() const {
  const Vec3 phi = R_.log();
  Vec6 xi;
  xi.head<3>() = SO3d::leftJacobianInverse(phi) * t_;
  xi.tail<3>() = phi;
  return xi;
}

SE3d SE3d::inverse() const {
  const SO3d Ri = R_.inverse();
  return SE3d(Ri, -(Ri * t_));
}

Mat4 SE3d::matrix() const {
  Mat4 T = Mat4::Identity();
  T.topLeftCorner<3, 3>() = R_.matrix();
  T.topRightCorner<3, 1>() = t_;
  return T;
}

Mat6 SE3d::adjoint() const {
  const Mat3 R = R_.matrix();
  Mat6 A = Mat6::Zero();
  A.topLeftCorner<3, 3>() = R;
  A.bottomRightCorner<3, 3>() = R;
  A.topRightCorner<3, 3>() = hat(t_) * R;
  return A;
}

Mat6 SE3d::rightJacobian(const Vec6& xi) { return leftJacobianSE3(-xi); }
Mat6 SE3d::rightJacobianInverse(const Vec6& xi) { return leftJacobianInverseSE3(-xi); }

SE3d compose(const SE3d& z12, const SE3d& z23, Mat6* J_z12, Mat6* J_z23) {
  if (J_z12) *J_z12 = z23.inverse().adjoint();
  if (J_z23) *J_z23 = Mat6::Identity();
  return z12 * z23;
}

SE3d inverse(const SE3d& z, Mat6* J_z) {
  if (J_z) *J_z = -z.adjoint();
  return z.inverse();
}

SE3d between(const SE3d& a, const SE3d& b, Mat6* J_a, Mat6* J_b) {
  const SE3d ab = a.inverse() * b;
  if (J_a) *J_a = -ab.inverse().adjoint();
  if (J_b) *J_b = Mat6::Identity();
  return ab;
}

UncertainPose compound(const UncertainPose& z12, const UncertainPose& z23) {
  Mat6 J1;
  Mat6 J2;
  UncertainPose out;
  out.mean = compose(z12.mean, z23.mean, &J1, &J2);
  // eq. (7): first-order covariance, z12 and z23 independent.
  out.covariance = J1 * z12.covariance * J1.transpose() + J2 * z23.covariance * J2.transpose();
  out.covariance = 0.5 * (out.covariance + out.covariance.transpose()).eval();
  return out;
}

UncertainPose invert(const UncertainPose& z) {
  Mat6 J;
  UncertainPose out;
  out.mean = inverse(z.mean, &J);
  out.covariance = J * z.covariance * J.transpose();
  out.covariance = 0.5 * (out.covariance + out.covariance.transpose()).eval();
  return out;
}

double rotationAngle(const SO3d& R) { return R.log().norm(); }

}  // namespace evermap::core
