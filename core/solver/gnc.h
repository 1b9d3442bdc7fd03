#pragma once
// Graduated non-convexity with the truncated least squares cost (GNC-TLS): Yang, Antonante,
// Tzoumas & Carlone, "Graduated Non-Convexity for Robust Spatial Perception: From
// Non-Minimal Solvers to Global Outlier Rejection", RA-L 2020, Algorithm 1 and Remark 5.
//
// Factors carrying a KernelType::kGncTls kernel (threshold c̄²) are the candidates; the rest
// are trusted. μ starts at c̄²/(2 s_max − c̄²) (s_max the largest candidate's squared error at
// the initial values, where the surrogate is convex over all of them), and each stage
// minimises the surrogate ρ_μ with Gauss-Newton and IRLS weights (the Black-Rangarajan
// alternation of weights and variables), then multiplies μ by `mu_factor`. It stops when
// every weight is within `binary_tolerance` of 0 or 1 (Σ w(1−w) small: the surrogate has
// become TLS at the solution) and a last stage at that μ runs with the caller's full
// budget and tolerances; that stage's termination is the summary's.
// Batch only: the stages re-solve the whole problem (no incremental form).

#include "core/solver/batch_solver.h"

namespace evermap::solver {

struct GncOptions {
  // The last stage's method, budget and tolerances.
  BatchOptions final_stage;
  // Budget and tolerance of each intermediate stage (a stage need not converge: μ moves on).
  int stage_max_iterations = 5;
  double stage_relative_tolerance = 1e-6;
  double mu_factor = 1.4;  // the paper's value
  int max_stages = 200;
  // Stop raising μ when max_i w_i (1 − w_i) is below this.
  double binary_tolerance = 1e-3;

  Status validate() const;
};

struct GncSummary {
  BatchSummary batch;  // the last stage; iterations are summed over all stages
  int stages = 0;
  double final_mu = 0.0;
  int candidates = 0;  // factors with a GNC kernel
  int rejected = 0;    // of those, weight < 0.5 at the end
};

GncSummary solveGnc(PoseGraph& graph, const GncOptions& options);

}  // namespace evermap::solver
