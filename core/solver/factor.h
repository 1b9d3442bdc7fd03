#pragma once
// The factor interface: residual + Jacobians + noise model (+ optional robust kernel).
//
// A factor measures some of the variables through a residual r(x) ∈ R^m whose whitened form
// W r (W = upper-triangular square root of the information matrix, WᵀW = Σ⁻¹) is
// standard-normal. The solver never looks inside a factor: a new factor type only implements
// evaluate(), so no solver change is needed to add one (GTSAM's NoiseModelFactor, Ceres's
// CostFunction). Jacobians are with respect to the retraction of core/solver/values.h and
// are checked against numerical derivatives in tests/solver_factors_test.cpp.

#include <memory>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/common/expected.h"
#include "core/solver/robust_kernel.h"
#include "core/solver/values.h"

namespace evermap::solver {

class Factor {
 public:
  // Contract: sqrt_information is square, upper triangular, finite (see the checked
  // builders below for input from files).
  Factor(std::vector<Key> keys, Eigen::MatrixXd sqrt_information);
  virtual ~Factor() = default;

  const std::vector<Key>& keys() const { return keys_; }
  int dim() const { return static_cast<int>(sqrt_information_.rows()); }
  const Eigen::MatrixXd& sqrtInformation() const { return sqrt_information_; }
  Eigen::MatrixXd information() const { return sqrt_information_.transpose() * sqrt_information_; }

  const RobustKernel& kernel() const { return kernel_; }
  void setKernel(const RobustKernel& kernel) { kernel_ = kernel; }

  // The kind of variable expected at keys()[i].
  virtual PoseKind kindOf(int i) const = 0;
  virtual std::string name() const = 0;

  // Unwhitened residual r(x) into residual[0, dim()), and when jacobians != nullptr, for
  // every i with jacobians[i] != nullptr, ∂r/∂δ_i into jacobians[i] (column-major,
  // dim() x x[i]->dim()). x[i] is the value of keys()[i].
  virtual void evaluate(std::span<const PoseValue* const> x, double* residual,
                        double* const* jacobians) const = 0;

 private:
  std::vector<Key> keys_;
  Eigen::MatrixXd sqrt_information_;
  RobustKernel kernel_;
};

using FactorPtr = std::shared_ptr<Factor>;

// Square root information from an information matrix: W = Lᵀ with LLᵀ = I. Errors when the
// matrix holds NaN/Inf, is not symmetric or not positive definite; `what` names the input.
Expected<Eigen::MatrixXd> sqrtInformationFromInformation(const Eigen::MatrixXd& information,
                                                         const std::string& what);
// Checks an upper-triangular square root information matrix (iSAM's files): finite, upper
// triangular, non-zero diagonal.
Expected<Eigen::MatrixXd> checkSqrtInformation(const Eigen::MatrixXd& sqrt_information,
                                               const std::string& what);

// Central-difference Jacobians of a factor at x (for tests and for new factor types).
std::vector<Eigen::MatrixXd> numericalJacobians(const Factor& factor,
                                                std::span<const PoseValue* const> x,
                                                double step = 1e-6);

}  // namespace evermap::solver
