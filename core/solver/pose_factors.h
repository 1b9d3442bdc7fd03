#pragma once
// Pose-graph factors. Residual conventions are written out because χ² values published by
// other tools are only comparable under their own residual:
//
// RelativePose2Factor, between poses a and b with measurement z (b in a's frame):
//   kIsam: r = [R_aᵀ(t_b − t_a) − t_z ; wrap(θ_b − θ_a − θ_z)]        (iSAM 1.6 slam2d.h)
//   kG2o:  r = [R_zᵀ(R_aᵀ(t_b − t_a) − t_z) ; wrap(θ_b − θ_a − θ_z)]  (g2o EdgeSE2: z⁻¹ a⁻¹ b)
// RelativePose3Factor, δ = z⁻¹ a⁻¹ b, p = a⁻¹ b:
//   kLog:       r = log(δ) = (υ, ω)                                      (GTSAM BetweenFactor)
//   kG2o:       r = [t_δ ; q_δ.xyz] with q_δ.w ≥ 0                       (g2o EdgeSE3)
//   kIsamEuler: r = [t_p − t_z ; wrap(ypr(R_p) − ypr(R_z))], ypr = (yaw, pitch, roll) of
//               R = Rz(yaw) Ry(pitch) Rx(roll)                           (iSAM 1.6 slam3d.h)
// ChordalRelativePose{2,3}Factor: SE-Sync's isotropic chordal cost (Rosen et al., IJRR 2019,
//   eq. 13): r = [√τ (t_b − t_a − R_a t_z) ; √κ vec(R_b − R_a R_z)], so Σ‖r‖² = f exactly.
// PosePrior2Factor: r = [t − t_m ; wrap(θ − θ_m)]. PosePrior3Factor: r = [t − t_m ; log(R_mᵀR)].
// RollPitchFactor: r = wrap([roll(R) − roll_m ; pitch(R) − pitch_m]) (an IMU's attitude).
// HeightFactor: r = t_z − z_m (a floor height).

#include "core/solver/factor.h"

namespace evermap::solver {

class RelativePose2Factor final : public Factor {
 public:
  enum class Convention { kIsam, kG2o };
  RelativePose2Factor(Key a, Key b, const core::SE2d& a_T_b, Eigen::MatrixXd sqrt_information,
                      Convention convention = Convention::kG2o);
  PoseKind kindOf(int) const override { return PoseKind::kSE2; }
  std::string name() const override { return "RelativePose2"; }
  void evaluate(std::span<const PoseValue* const> x, double* residual,
                double* const* jacobians) const override;
  const core::SE2d& measurement() const { return z_; }
  Convention convention() const { return convention_; }

 private:
  core::SE2d z_;
  Convention convention_;
};

class RelativePose3Factor final : public Factor {
 public:
  enum class Convention { kLog, kG2o, kIsamEuler };
  RelativePose3Factor(Key a, Key b, const core::SE3d& a_T_b, Eigen::MatrixXd sqrt_information,
                      Convention convention = Convention::kG2o);
  PoseKind kindOf(int) const override { return PoseKind::kSE3; }
  std::string name() const override { return "RelativePose3"; }
  void evaluate(std::span<const PoseValue* const> x, double* residual,
                double* const* jacobians) const override;
  const core::SE3d& measurement() const { return z_; }
  Convention convention() const { return convention_; }

 private:
  core::SE3d z_;
  core::SE3d z_inv_;
  core::Vec3 ypr_z_;
  Convention convention_;
};

class ChordalRelativePose2Factor final : public Factor {
 public:
  ChordalRelativePose2Factor(Key a, Key b, const core::SE2d& a_T_b, double kappa, double tau);
  PoseKind kindOf(int) const override { return PoseKind::kSE2; }
  std::string name() const override { return "ChordalRelativePose2"; }
  void evaluate(std::span<const PoseValue* const> x, double* residual,
                double* const* jacobians) const override;

 private:
  core::SE2d z_;
};

class ChordalRelativePose3Factor final : public Factor {
 public:
  ChordalRelativePose3Factor(Key a, Key b, const core::SE3d& a_T_b, double kappa, double tau);
  PoseKind kindOf(int) const override { return PoseKind::kSE3; }
  std::string name() const override { return "ChordalRelativePose3"; }
  void evaluate(std::span<const PoseValue* const> x, double* residual,
                double* const* jacobians) const override;

 private:
  core::SE3d z_;
};

class PosePrior2Factor final : public Factor {
 public:
  PosePrior2Factor(Key key, const core::SE2d& prior, Eigen::MatrixXd sqrt_information);
  PoseKind kindOf(int) const override { return PoseKind::kSE2; }
  std::string name() const override { return "PosePrior2"; }
  void evaluate(std::span<const PoseValue* const> x, double* residual,
                double* const* jacobians) const override;

 private:
  core::SE2d prior_;
};

class PosePrior3Factor final : public Factor {
 public:
  PosePrior3Factor(Key key, const core::SE3d& prior, Eigen::MatrixXd sqrt_information);
  PoseKind kindOf(int) const override { return PoseKind::kSE3; }
  std::string name() const override { return "PosePrior3"; }
  void evaluate(std::span<const PoseValue* const> x, double* residual,
                double* const* jacobians) const override;

 private:
  core::SE3d prior_;
};

// Partial prior on roll and pitch only (yaw and translation unobserved), radians.
class RollPitchFactor final : public Factor {
 public:
  RollPitchFactor(Key key, double roll, double pitch, Eigen::MatrixXd sqrt_information);
  PoseKind kindOf(int) const override { return PoseKind::kSE3; }
  std::string name() const override { return "RollPitch"; }
  void evaluate(std::span<const PoseValue* const> x, double* residual,
                double* const* jacobians) const override;

 private:
  double roll_;
  double pitch_;
};

// Partial prior on the height t_z only, metres.
class HeightFactor final : public Factor {
 public:
  HeightFactor(Key key, double z_m, double sigma_m);
  PoseKind kindOf(int) const override { return PoseKind::kSE3; }
  std::string name() const override { return "Height"; }
  void evaluate(std::span<const PoseValue* const> x, double* residual,
                double* const* jacobians) const override;

 private:
  double z_m_;
};

// (yaw, pitch, roll) of R = Rz(yaw) Ry(pitch) Rx(roll), as iSAM's Rot3d::quat_to_euler.
core::Vec3 yawPitchRoll(const core::Mat3& R);
// ∂(yaw, pitch, roll)/∂ε of R exp(ε) (singular at pitch = ±π/2).
core::Mat3 yawPitchRollJacobian(const core::Mat3& R);

}  // namespace evermap::solver
