#pragma once
// Point-landmark factors: a pose observes a point given in the pose's own frame.
//
// PosePoint2Factor, pose a ∈ SE(2), point l ∈ R², measurement z (the point in a's frame):
//   r = R_aᵀ (l − t_a) − z                         iSAM 1.6 Pose2d_Point2d_Factor (LANDMARK
//                                                    lines) and g2o EdgeSE2PointXY (EDGE_SE2_XY)
// PosePoint3Factor, pose a ∈ SE(3), point l ∈ R³, sensor offset a_T_s (identity unless a g2o
// PARAMS_SE3OFFSET says otherwise):
//   r = (a_T_s)⁻¹ a⁻¹ l − z = R_sᵀ (R_aᵀ (l − t_a) − t_s) − z
//                                                    iSAM 1.6 Pose3d_Point3d_Factor (POINT3)
//                                                    and g2o EdgeSE3PointXYZ (EDGE_SE3_TRACKXYZ)
// Both tools use this residual, so the weighted SSE of a file is comparable with theirs.
// Jacobians under the retractions of core/solver/values.h, with p = R_aᵀ (l − t_a):
//   2-D: ∂r/∂(υ, ω) = [−I  (p_y, −p_x)ᵀ],   ∂r/∂l = R_aᵀ
//   3-D: ∂r/∂(υ, ω) = R_sᵀ [−I  [p]×],      ∂r/∂l = R_sᵀ R_aᵀ
// (checked against numerical derivatives in tests/solver_landmarks_test.cpp). A landmark
// first seen is initialised as a ⊕ z = a · a_T_s · z (observationInitialValue).

#include "core/solver/factor.h"

namespace evermap::solver {

class PosePoint2Factor final : public Factor {
 public:
  PosePoint2Factor(Key pose, Key point, const core::Vec2& p_pose, Eigen::MatrixXd sqrt_information);
  PoseKind kindOf(int i) const override { return i == 0 ? PoseKind::kSE2 : PoseKind::kPoint2; }
  std::string name() const override { return "PosePoint2"; }
  void evaluate(std::span<const PoseValue* const> x, double* residual,
                double* const* jacobians) const override;
  const core::Vec2& measurement() const { return z_; }

 private:
  core::Vec2 z_;
};

class PosePoint3Factor final : public Factor {
 public:
  PosePoint3Factor(Key pose, Key point, const core::Vec3& p_sensor,
                   Eigen::MatrixXd sqrt_information,
                   const core::SE3d& pose_T_sensor = core::SE3d());
  PoseKind kindOf(int i) const override { return i == 0 ? PoseKind::kSE3 : PoseKind::kPoint3; }
  std::string name() const override { return "PosePoint3"; }
  void evaluate(std::span<const PoseValue* const> x, double* residual,
                double* const* jacobians) const override;
  const core::Vec3& measurement() const { return z_; }

 private:
  core::Vec3 z_;
  core::SE3d pose_T_sensor_;
  bool has_offset_;
};

// The world position a ⊕ z of a point measured as z in the frame of pose a (2-D: z.z()
// ignored), of the point kind that matches the pose: the initial value of a new landmark.
PoseValue observationInitialValue(const PoseValue& pose, const core::Vec3& z,
                                  const core::SE3d& pose_T_sensor = core::SE3d());

}  // namespace evermap::solver
