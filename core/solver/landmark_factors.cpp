#include "core/solver/landmark_factors.h"

#include <cstdio>
#include <cstdlib>

namespace evermap::solver {
namespace {

using core::Mat2;
using core::Mat3;
using core::Vec2;
using core::Vec3;
using MapJ = Eigen::Map<Eigen::MatrixXd>;

bool wants(double* const* jacobians, int i) { return jacobians && jacobians[i]; }

}  // namespace

PosePoint2Factor::PosePoint2Factor(Key pose, Key point, const Vec2& p_pose,
                                   Eigen::MatrixXd sqrt_information)
    : Factor({pose, point}, std::move(sqrt_information)), z_(p_pose) {}

void PosePoint2Factor::evaluate(std::span<const PoseValue* const> x, double* residual,
                                double* const* jacobians) const {
  const core::SE2d& a = x[0]->se2;
  const Vec2 l = x[1]->point.head<2>();
  const Mat2 Rt = a.rotationMatrix().transpose();
  const Vec2 p = Rt * (l - a.translation());
  Eigen::Map<Vec2> r(residual);
  r = p - z_;
  if (wants(jacobians, 0)) {
    MapJ J(jacobians[0], 2, 3);
    J.leftCols<2>() = -Mat2::Identity();
    J.col(2) = Vec2(p.y(), -p.x());
  }
  if (wants(jacobians, 1)) {
    MapJ J(jacobians[1], 2, 2);
    J = Rt;
  }
}

PosePoint3Factor::PosePoint3Factor(Key pose, Key point, const Vec3& p_sensor,
                                   Eigen::MatrixXd sqrt_information,
                                   const core::SE3d& pose_T_sensor)
    : Factor({pose, point}, std::move(sqrt_information)),
      z_(p_sensor),
      pose_T_sensor_(pose_T_sensor),
      has_offset_(!pose_T_sensor.translation().isZero(0.0) ||
                  !pose_T_sensor.rotationMatrix().isIdentity(0.0)) {}

void PosePoint3Factor::evaluate(std::span<const PoseValue* const> x, double* residual,
                                double* const* jacobians) const {
  const core::SE3d& a = x[0]->se3;
  const Vec3& l = x[1]->point;
  const Mat3 Rt = a.rotationMatrix().transpose();
  const Vec3 p = Rt * (l - a.translation());  // the point in the pose's frame
  Mat3 front = Mat3::Identity();              // R_sᵀ
  Vec3 p_s = p;
  if (has_offset_) {
    front = pose_T_sensor_.rotationMatrix().transpose();
    p_s = front * (p - pose_T_sensor_.translation());
  }
  Eigen::Map<Vec3> r(residual);
  r = p_s - z_;
  if (wants(jacobians, 0)) {
    MapJ J(jacobians[0], 3, 6);
    J.leftCols<3>() = -front;
    J.rightCols<3>() = front * core::hat(p);
  }
  if (wants(jacobians, 1)) {
    MapJ J(jacobians[1], 3, 3);
    J = front * Rt;
  }
}

PoseValue observationInitialValue(const PoseValue& pose, const Vec3& z,
                                  const core::SE3d& pose_T_sensor) {
  switch (pose.kind) {
    case PoseKind::kSE2:
      return PoseValue::point2(pose.se2 * Vec2(z.x(), z.y()));
    case PoseKind::kSE3:
      return PoseValue::point3(pose.se3 * (pose_T_sensor * z));
    default:
      std::fprintf(stderr, "evermap: observationInitialValue: the observer is not a pose\n");
      std::abort();
  }
}

}  // namespace evermap::solver
