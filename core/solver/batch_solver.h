#pragma once
// Batch nonlinear least squares on a PoseGraph: Gauss-Newton, Levenberg-Marquardt or
// Powell's dog leg, each step solving the normal equations by supernodal Cholesky
// (CHOLMOD) under a CCOLAMD block ordering. Robust kernels enter by IRLS reweighting at
// every linearisation.
//
// Dog leg: Powell (1970); the trust-region update and gain ratio follow Madsen, Nielsen &
// Tingleff, "Methods for non-linear least squares problems" (2004), section 3.3, as iSAM's
// Optimizer does. Levenberg-Marquardt: Marquardt's scaling (H + λ diag H).

#include <string>

#include "core/common/expected.h"
#include "core/solver/pose_graph.h"

namespace evermap::solver {

enum class Method { kGaussNewton, kLevenbergMarquardt, kDogLeg };
const char* methodName(Method m);
Expected<Method> parseMethod(const std::string& text);  // "gn", "lm", "dogleg"

struct BatchOptions {
  Method method = Method::kGaussNewton;
  // Stop after this many iterations (linearisations).
  int max_iterations = 100;
  // Converged when an accepted step lowers the cost by less than this fraction of it.
  double relative_cost_tolerance = 1e-10;
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
  kSmallStep,      // step below tolerance
  kMaxIterations,  // iteration limit reached (estimate is the best found)
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
  int64_t factor_nnz = 0;     // non-zeros of the last Cholesky factor
  bool ok() const { return termination != Termination::kFailure; }
};

// Powell's dog-leg step inside radius Δ from the Gauss-Newton step h_gn and the Cauchy step
// h_sd (Madsen, Nielsen & Tingleff 2004, eq. 3.20).
Eigen::VectorXd dogLegStep(const Eigen::VectorXd& h_gn, const Eigen::VectorXd& h_sd,
                           double radius);

// Minimises the graph's robust cost starting from its current values; updates the values.
BatchSummary solveBatch(PoseGraph& graph, const BatchOptions& options);

}  // namespace evermap::solver
