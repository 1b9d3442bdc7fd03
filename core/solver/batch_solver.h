#pragma once
// Batch nonlinear least squares on a PoseGraph: Gauss-Newton, Levenberg-Marquardt or
// Powell's dog leg, each step solving the normal equations by supernodal Cholesky
// (CHOLMOD) under a CCOLAMD block ordering. Robust kernels enter by IRLS reweighting at
// every linearisation.
//
// Dog leg: Powell (1970); the trust-region update and gain ratio follow Madsen, Nielsen &
// Tingleff, "Methods for non-linear least squares problems" (2004), section 3.3, as iSAM's
// Optimizer does. Levenberg-Marquardt: Marquardt's scaling (H + λ diag H).

#include <limits>
#include <string>

#include "core/common/expected.h"
#include "core/solver/pose_graph.h"

namespace evermap::solver {

enum class Method { kGaussNewton, kLevenbergMarquardt, kDogLeg };
const char* methodName(Method m);

struct BatchOptions {
  Method method = Method::kGaussNewton;
  // The budget: stop after this many iterations (linearisations, rejected LM/dog-leg
  // steps included) and report Termination::kMaxIterations — not converged. 1000 lets every
  // public benchmark file present converge, including SE-Sync's chordal cost, on which
  // Gauss-Newton converges only linearly (docs/solver.md lists the counts).
  int max_iterations = 1000;
  // Converged when an accepted step lowers the cost by less than this fraction of it.
  double relative_cost_tolerance = 1e-10;
  // Converged when the largest entry of the gradient Jᵀ W ρ' W r of the (robust) cost at the
  // current estimate is at most this (cost units per metre / radian), checked before every
  // iteration, so a start at a minimum takes no iteration. Ceres's gradient_tolerance.
  double gradient_tolerance = 1e-10;
  // Converged when the step's largest entry (metres / radians) is below this.
  double step_tolerance = 1e-10;
  // Levenberg-Marquardt: initial λ and its factor on failure (divided on success).
  double lm_initial_lambda = 1e-5;
  double lm_lambda_factor = 10.0;
  // Dog leg: initial trust-region radius (in the stacked tangent step, metres/radians).
  double initial_trust_radius = 1.0;
  // Print one line per iteration to stderr.
  bool verbose = false;

  Status validate() const;
};

enum class Termination {
  kConverged,      // relative cost decrease below tolerance
  kSmallGradient,  // gradient below tolerance
  kSmallStep,      // step below tolerance
  kMaxIterations,  // iteration budget exhausted before a convergence test held: NOT converged
                   // (the estimate is the best found)
  kFailure,        // linear system singular or not positive definite
};
const char* terminationName(Termination t);

struct BatchSummary {
  Termination termination = Termination::kFailure;
  std::string message;
  int iterations = 0;
  int factorizations = 0;
  double initial_cost = 0.0;  // robust cost Σρ at the start
  double final_cost = 0.0;    // robust cost Σρ at the end
  double final_weighted_sse = 0.0;
  int64_t factor_nnz = 0;  // non-zeros of the last Cholesky factor
  // At the end: ‖g‖∞ of the gradient at the final estimate, and |Δcost|/cost of the last
  // accepted step (NaN when no step was accepted).
  double final_gradient_max = 0.0;
  double last_relative_decrease = std::numeric_limits<double>::quiet_NaN();
  // False only on a failure (no usable estimate). Not the same as converged().
  bool ok() const { return termination != Termination::kFailure; }
  // One of the convergence tests held (relative decrease, gradient or step).
  bool converged() const {
    return termination == Termination::kConverged || termination == Termination::kSmallGradient ||
           termination == Termination::kSmallStep;
  }
};

// Powell's dog-leg step inside radius Δ from the Gauss-Newton step h_gn and the Cauchy step
// h_sd (Madsen, Nielsen & Tingleff 2004, eq. 3.20).
Eigen::VectorXd dogLegStep(const Eigen::VectorXd& h_gn, const Eigen::VectorXd& h_sd, double radius);

// Minimises the graph's robust cost starting from its current values; updates the values.
BatchSummary solveBatch(PoseGraph& graph, const BatchOptions& options);

}  // namespace evermap::solver
