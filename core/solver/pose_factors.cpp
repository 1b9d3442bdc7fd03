#include "core/solver/pose_factors.h"

#include <algorithm>
#include <cmath>

namespace evermap::solver {
namespace {

using core::Mat2;
using core::Mat3;
using core::Mat6;
using core::Vec2;
using core::Vec3;
using core::Vec6;
using Mat3x6 = Eigen::Matrix<double, 3, 6>;
using MapJ = Eigen::Map<Eigen::MatrixXd>;

// d R(θ)/dθ = R(θ) S with S the planar cross-product matrix.
const Mat2 kS = (Mat2() << 0.0, -1.0, 1.0, 0.0).finished();

bool wants(double* const* jacobians, int i) { return jacobians && jacobians[i]; }

// d(roll, pitch, yaw)/dε for R exp(ε): the inverse of the ZYX body-rate map.
Mat3 eulerRateFromBodyRate(double roll, double pitch) {
  const double sr = std::sin(roll);
  const double cr = std::cos(roll);
  const double tp = std::tan(pitch);
  const double cp = std::cos(pitch);
  Mat3 E;
  E << 1.0, sr * tp, cr * tp, 0.0, cr, -sr, 0.0, sr / cp, cr / cp;
  return E;  // rows: roll, pitch, yaw
}

}  // namespace

Vec3 yawPitchRoll(const Mat3& R) {
  const Eigen::Quaterniond q(R);
  const double w = q.w();
  const double x = q.x();
  const double y = q.y();
  const double z = q.z();
  const double roll = std::atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y));
  const double pitch = std::asin(std::clamp(2.0 * (w * y - z * x), -1.0, 1.0));
  const double yaw = std::atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z));
  return Vec3(yaw, pitch, roll);
}

Mat3 yawPitchRollJacobian(const Mat3& R) {
  const Vec3 ypr = yawPitchRoll(R);
  const Mat3 E = eulerRateFromBodyRate(ypr[2], ypr[1]);
  Mat3 D;
  D.row(0) = E.row(2);
  D.row(1) = E.row(1);
  D.row(2) = E.row(0);
  return D;
}

// ---------------------------------------------------------------- RelativePose2Factor

RelativePose2Factor::RelativePose2Factor(Key a, Key b, const core::SE2d& a_T_b,
                                         Eigen::MatrixXd sqrt_information, Convention convention)
    : Factor({a, b}, std::move(sqrt_information)), z_(a_T_b), convention_(convention) {}

void RelativePose2Factor::evaluate(std::span<const PoseValue* const> x, double* residual,
                                   double* const* jacobians) const {
  const core::SE2d& a = x[0]->se2;
  const core::SE2d& b = x[1]->se2;
  const Mat2 Ra = a.rotationMatrix();
  const Vec2 p = Ra.transpose() * (b.translation() - a.translation());
  Vec2 rt = p - z_.translation();
  Mat2 front = Mat2::Identity();  // R_zᵀ for g2o, I for iSAM
  if (convention_ == Convention::kG2o) {
    front = z_.rotationMatrix().transpose();
    rt = front * rt;
  }
  residual[0] = rt.x();
  residual[1] = rt.y();
  residual[2] = core::wrapAngle(b.theta() - a.theta() - z_.theta());
  if (wants(jacobians, 0)) {
    MapJ J(jacobians[0], 3, 3);
    J.setZero();
    J.topLeftCorner<2, 2>() = -front;
    J.topRightCorner<2, 1>() = front * Vec2(p.y(), -p.x());
    J(2, 2) = -1.0;
  }
  if (wants(jacobians, 1)) {
    MapJ J(jacobians[1], 3, 3);
    J.setZero();
    J.topLeftCorner<2, 2>() = front * Ra.transpose() * b.rotationMatrix();
    J(2, 2) = 1.0;
  }
}

// ---------------------------------------------------------------- RelativePose3Factor

RelativePose3Factor::RelativePose3Factor(Key a, Key b, const core::SE3d& a_T_b,
                                         Eigen::MatrixXd sqrt_information, Convention convention)
    : Factor({a, b}, std::move(sqrt_information)),
      z_(a_T_b),
      z_inv_(a_T_b.inverse()),
      ypr_z_(yawPitchRoll(a_T_b.rotationMatrix())),
      convention_(convention) {}

void RelativePose3Factor::evaluate(std::span<const PoseValue* const> x, double* residual,
                                   double* const* jacobians) const {
  const core::SE3d& a = x[0]->se3;
  const core::SE3d& b = x[1]->se3;
  Eigen::Map<Vec6> r(residual);
  const core::SE3d p = a.inverse() * b;  // predicted a_T_b
  const bool any_jacobian = wants(jacobians, 0) || wants(jacobians, 1);

  if (convention_ == Convention::kIsamEuler) {
    const Mat3 Rp = p.rotationMatrix();
    const Vec3 ypr = yawPitchRoll(Rp);
    r.head<3>() = p.translation() - z_.translation();
    for (int k = 0; k < 3; ++k) r[3 + k] = core::wrapAngle(ypr[k] - ypr_z_[k]);
    if (!any_jacobian) return;
    // d(yaw, pitch, roll)/dε for a right perturbation ε of R_p.
    const Mat3 D = yawPitchRollJacobian(Rp);
    if (wants(jacobians, 0)) {
      MapJ J(jacobians[0], 6, 6);
      J.setZero();
      J.topLeftCorner<3, 3>() = -Mat3::Identity();
      J.topRightCorner<3, 3>() = core::hat(p.translation());
      J.bottomRightCorner<3, 3>() = -D * Rp.transpose();
    }
    if (wants(jacobians, 1)) {
      MapJ J(jacobians[1], 6, 6);
      J.setZero();
      J.topLeftCorner<3, 3>() = Rp;
      J.bottomRightCorner<3, 3>() = D;
    }
    return;
  }

  const core::SE3d delta = z_inv_ * p;
  Mat6 local;  // ∂r/∂ε for δ exp(ε)
  if (convention_ == Convention::kLog) {
    r = delta.log();
    if (any_jacobian) local = core::SE3d::rightJacobianInverse(r);
  } else {
    Eigen::Quaterniond q = delta.quaternion();
    const double sign = q.w() < 0.0 ? -1.0 : 1.0;
    r.head<3>() = delta.translation();
    r.tail<3>() = sign * q.vec();
    if (any_jacobian) {
      local.setZero();
      local.topLeftCorner<3, 3>() = delta.rotationMatrix();
      local.bottomRightCorner<3, 3>() =
          0.5 * sign * (q.w() * Mat3::Identity() + core::hat(q.vec()));
    }
  }
  if (wants(jacobians, 0)) {
    // δ(a exp(ξ)) = δ exp(−Ad(b⁻¹ a) ξ).
    MapJ J(jacobians[0], 6, 6);
    J = -local * (b.inverse() * a).adjoint();
  }
  if (wants(jacobians, 1)) {
    MapJ J(jacobians[1], 6, 6);
    J = local;
  }
}

// ---------------------------------------------------------------- Chordal factors

namespace {
Eigen::MatrixXd chordalWeights(int d, double kappa, double tau) {
  const int m = d + d * d;
  Eigen::MatrixXd W = Eigen::MatrixXd::Zero(m, m);
  for (int i = 0; i < d; ++i) W(i, i) = std::sqrt(tau);
  for (int i = d; i < m; ++i) W(i, i) = std::sqrt(kappa);
  return W;
}
}  // namespace

ChordalRelativePose2Factor::ChordalRelativePose2Factor(Key a, Key b, const core::SE2d& a_T_b,
                                                       double kappa, double tau)
    : Factor({a, b}, chordalWeights(2, kappa, tau)), z_(a_T_b) {}

void ChordalRelativePose2Factor::evaluate(std::span<const PoseValue* const> x, double* residual,
                                          double* const* jacobians) const {
  const core::SE2d& a = x[0]->se2;
  const core::SE2d& b = x[1]->se2;
  const Mat2 Ra = a.rotationMatrix();
  const Mat2 Rb = b.rotationMatrix();
  const Mat2 Rz = z_.rotationMatrix();
  const Vec2 tz = z_.translation();
  Eigen::Map<Vec2> rt(residual);
  Eigen::Map<Mat2> rR(residual + 2);  // column-major vec
  rt = b.translation() - a.translation() - Ra * tz;
  rR = Rb - Ra * Rz;
  if (wants(jacobians, 0)) {
    MapJ J(jacobians[0], 6, 3);
    J.setZero();
    J.topLeftCorner<2, 2>() = -Ra;
    J.block<2, 1>(0, 2) = -Ra * kS * tz;
    const Mat2 dR = -Ra * kS * Rz;
    J.block<4, 1>(2, 2) = Eigen::Map<const Eigen::Vector4d>(dR.data());
  }
  if (wants(jacobians, 1)) {
    MapJ J(jacobians[1], 6, 3);
    J.setZero();
    J.topLeftCorner<2, 2>() = Rb;
    const Mat2 dR = Rb * kS;
    J.block<4, 1>(2, 2) = Eigen::Map<const Eigen::Vector4d>(dR.data());
  }
}

ChordalRelativePose3Factor::ChordalRelativePose3Factor(Key a, Key b, const core::SE3d& a_T_b,
                                                       double kappa, double tau)
    : Factor({a, b}, chordalWeights(3, kappa, tau)), z_(a_T_b) {}

void ChordalRelativePose3Factor::evaluate(std::span<const PoseValue* const> x, double* residual,
                                          double* const* jacobians) const {
  const core::SE3d& a = x[0]->se3;
  const core::SE3d& b = x[1]->se3;
  const Mat3 Ra = a.rotationMatrix();
  const Mat3 Rb = b.rotationMatrix();
  const Mat3 Rz = z_.rotationMatrix();
  const Vec3& tz = z_.translation();
  Eigen::Map<Vec3> rt(residual);
  Eigen::Map<Mat3> rR(residual + 3);  // column-major vec
  rt = b.translation() - a.translation() - Ra * tz;
  rR = Rb - Ra * Rz;
  if (wants(jacobians, 0)) {
    MapJ J(jacobians[0], 12, 6);
    J.setZero();
    J.topLeftCorner<3, 3>() = -Ra;
    J.block<3, 3>(0, 3) = Ra * core::hat(tz);
    for (int c = 0; c < 3; ++c) J.block<3, 3>(3 + 3 * c, 3) = Ra * core::hat(Rz.col(c));
  }
  if (wants(jacobians, 1)) {
    MapJ J(jacobians[1], 12, 6);
    J.setZero();
    J.topLeftCorner<3, 3>() = Rb;
    for (int c = 0; c < 3; ++c) J.block<3, 3>(3 + 3 * c, 3) = -Rb * core::hat(Vec3::Unit(c));
  }
}

// ---------------------------------------------------------------- Priors

PosePrior2Factor::PosePrior2Factor(Key key, const core::SE2d& prior,
                                   Eigen::MatrixXd sqrt_information)
    : Factor({key}, std::move(sqrt_information)), prior_(prior) {}

void PosePrior2Factor::evaluate(std::span<const PoseValue* const> x, double* residual,
                                double* const* jacobians) const {
  const core::SE2d& p = x[0]->se2;
  residual[0] = p.x() - prior_.x();
  residual[1] = p.y() - prior_.y();
  residual[2] = core::wrapAngle(p.theta() - prior_.theta());
  if (wants(jacobians, 0)) {
    MapJ J(jacobians[0], 3, 3);
    J.setZero();
    J.topLeftCorner<2, 2>() = p.rotationMatrix();
    J(2, 2) = 1.0;
  }
}

PosePrior3Factor::PosePrior3Factor(Key key, const core::SE3d& prior,
                                   Eigen::MatrixXd sqrt_information)
    : Factor({key}, std::move(sqrt_information)), prior_(prior) {}

void PosePrior3Factor::evaluate(std::span<const PoseValue* const> x, double* residual,
                                double* const* jacobians) const {
  const core::SE3d& p = x[0]->se3;
  Eigen::Map<Vec6> r(residual);
  r.head<3>() = p.translation() - prior_.translation();
  const Vec3 phi = (prior_.so3().inverse() * p.so3()).log();
  r.tail<3>() = phi;
  if (wants(jacobians, 0)) {
    MapJ J(jacobians[0], 6, 6);
    J.setZero();
    J.topLeftCorner<3, 3>() = p.rotationMatrix();
    J.bottomRightCorner<3, 3>() = core::SO3d::rightJacobianInverse(phi);
  }
}

RollPitchFactor::RollPitchFactor(Key key, double roll, double pitch,
                                 Eigen::MatrixXd sqrt_information)
    : Factor({key}, std::move(sqrt_information)), roll_(roll), pitch_(pitch) {}

void RollPitchFactor::evaluate(std::span<const PoseValue* const> x, double* residual,
                               double* const* jacobians) const {
  const Vec3 ypr = yawPitchRoll(x[0]->se3.rotationMatrix());
  residual[0] = core::wrapAngle(ypr[2] - roll_);
  residual[1] = core::wrapAngle(ypr[1] - pitch_);
  if (wants(jacobians, 0)) {
    MapJ J(jacobians[0], 2, 6);
    J.setZero();
    const Mat3 E = eulerRateFromBodyRate(ypr[2], ypr[1]);
    J.block<2, 3>(0, 3) = E.topRows<2>();
  }
}

HeightFactor::HeightFactor(Key key, double z_m, double sigma_m)
    : Factor({key}, Eigen::MatrixXd::Constant(1, 1, 1.0 / sigma_m)), z_m_(z_m) {}

void HeightFactor::evaluate(std::span<const PoseValue* const> x, double* residual,
                            double* const* jacobians) const {
  const core::SE3d& p = x[0]->se3;
  residual[0] = p.translation().z() - z_m_;
  if (wants(jacobians, 0)) {
    MapJ J(jacobians[0], 1, 6);
    J.setZero();
    J.block<1, 3>(0, 0) = p.rotationMatrix().row(2);
  }
}

}  // namespace evermap::solver
