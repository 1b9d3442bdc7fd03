#pragma once
// iSAM: incremental smoothing and mapping on a square-root information matrix.
// Kaess, Ranganathan & Dellaert, "iSAM: Incremental Smoothing and Mapping", IEEE T-RO 2008;
// the incremental dog leg is RISE (Rosen, Kaess & Leonard, "RISE: An Incremental
// Trust-Region Method for Robust Online Sparse Least-Squares Estimation", T-RO 2014), as in
// iSAM 1.6, which the paper's mapper uses (section IV-E).
//
// State: a linearisation point θ (the graph's values), the factor R, d of all factors
// linearised at θ, and the step Δ; the estimate is θ ⊞ Δ.
//  - An incremental update linearises only the new factors at θ (new variables get θ = their
//    initial value) and eliminates their rows into R by orthogonal transformations; the work
//    follows the elimination-tree path of the new rows (core/solver/square_root_factor.h).
//    Gauss-Newton then solves R Δ = d by back substitution; dog leg takes RISE's
//    trust-region step from θ, accepted or rejected on the true cost.
//  - Every `batch_every` updates (and after a factor removal) a batch step relinearises all
//    factors at the estimate, reorders the variables (CCOLAMD) and refactors (CHOLMOD),
//    which bounds fill-in and linearisation error — iSAM's "periodic batch steps".
//  - With `background_batch_lag` = k > 0 a scheduled batch step leaves the update path: the
//    update that schedules it hands a copy of the graph at its estimate to a worker thread and
//    goes on incrementally; the k-th update after it takes the worker's factor (waiting for it
//    if it is not done) and re-applies the factors added in between. The filter/smoother split
//    of Kaess et al., "Concurrent Filtering and Smoothing", FUSION 2012, with the swap point
//    fixed by the update count, so the estimates never depend on the worker's speed.

#include <future>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "core/common/expected.h"
#include "core/solver/batch_solver.h"
#include "core/solver/pose_graph.h"
#include "core/solver/sparse_cholesky.h"
#include "core/solver/square_root_factor.h"

namespace evermap::solver {

struct IncrementalOptions {
  // Gauss-Newton or dog leg (Levenberg-Marquardt has no incremental form, as in iSAM).
  Method method = Method::kGaussNewton;
  // A batch step (relinearise, reorder, refactor) every this many updates; 0 = never
  // (except after removals). iSAM's default is 100.
  int batch_every = 100;
  // Partial back substitution: stop propagating a change smaller than this (metres and
  // radians, max-norm per variable). 0 solves exactly every update, as iSAM 1.6 does.
  double wildfire_threshold = 0.0;
  // Dog leg: initial trust-region radius.
  double initial_trust_radius = 1.0;
  // Batch steps order this many most recently added variables last (CCOLAMD constraint),
  // as iSAM2 does, so that measurements on recent poses touch fewer rows of R (on city10000
  // 8 % fewer rows modified per update than with 0, plain COLAMD as in iSAM 1.6).
  int recent_last = 10;
  // Scheduled batch steps in the background (Gauss-Newton only): 0 computes each inside the
  // update that schedules it, as iSAM does; k > 0 swaps it in k updates later (see above).
  // Batch steps forced by the caller, by a removal outside a scheduled update or by the first
  // update stay in the update.
  int background_batch_lag = 0;

  Status validate() const;
};

struct UpdateRequest {
  // New variables with their initial estimates (the caller's odometry chaining).
  std::vector<std::pair<Key, PoseValue>> new_variables;
  std::vector<FactorPtr> new_factors;
  // Factors to drop; any removal makes this update a batch step.
  std::vector<FactorId> remove_factors;
  // Make this update a batch step regardless of the schedule.
  bool force_batch = false;
};

struct UpdateResult {
  std::vector<FactorId> new_factor_ids;
  bool batch = false;         // this update was a batch step
  int rows_modified = 0;      // R row blocks changed by the new rows (incremental updates)
  int rows_solved = 0;        // row blocks recomputed by back substitution
  bool step_accepted = true;  // dog leg: the trust-region step lowered the cost
  // Background batch steps (IncrementalOptions::background_batch_lag): one was started at this
  // update / the one started background_batch_lag updates ago was swapped in at this update.
  bool batch_started = false;
  bool batch_swapped = false;
  // Measurement only (wall clock, never an input): the worker's time on the swapped batch,
  // and how long this update waited for it.
  double batch_compute_s = 0.0;
  double batch_wait_s = 0.0;
};

class IncrementalSolver {
 public:
  explicit IncrementalSolver(IncrementalOptions options = {});
  ~IncrementalSolver();  // waits for a background batch step in progress
  IncrementalSolver(const IncrementalSolver&) = delete;
  IncrementalSolver& operator=(const IncrementalSolver&) = delete;

  // Adds variables and factors (and removes factors), then updates the estimate.
  // On error (unknown key, kind mismatch, duplicate variable, singular system) nothing of
  // the request that failed validation is applied and the message names the cause.
  Expected<UpdateResult> update(const UpdateRequest& request);

  // A batch step now: relinearise at the estimate, reorder, refactor, solve. A background
  // batch step in progress is dropped (this one supersedes it).
  Status batchStep();
  // Batch optimisation to convergence from the current estimate (then a batch step so that
  // R matches the new linearisation point).
  BatchSummary optimize(const BatchOptions& options);

  const PoseGraph& graph() const { return graph_; }
  // θ ⊞ Δ.
  Values estimate() const;
  PoseValue estimate(Key key) const;
  // Cost at the estimate.
  Cost cost() const;
  // The square-root factor and the variable at each of its positions.
  const SquareRootFactor& squareRoot() const { return R_; }
  int positionOf(int variable) const { return position_of_[variable]; }
  int64_t nnz() const { return R_.nnz(); }
  int updates() const { return updates_; }
  // A background batch step is computing or waiting to be swapped in.
  bool batchPending() const { return job_.has_value(); }

 private:
  // A relinearised, reordered and refactored graph: what a batch step computes.
  struct Refactored {
    SquareRootFactor R;
    std::vector<int> variable_at;  // variable at each position
    Eigen::VectorXd delta;         // Gauss-Newton step at the new linearisation point
    double cost = 0.0;             // Σρ at the linearisation point
    double compute_s = 0.0;        // wall time (measurement only)
    Values theta;                  // the linearisation point (background batches only)
  };
  struct BackgroundBatch {
    std::future<Expected<Refactored>> result;
    int factor_slots = 0;    // factors with ids below this are in the snapshot
    int swap_at_update = 0;  // updates_ when it is swapped in
  };
  // Linearises `graph` at its values, orders (CCOLAMD, the `recent_last` newest variables
  // last), factors with CHOLMOD and solves for the Gauss-Newton step. Touches no member.
  static Expected<Refactored> refactor(const PoseGraph& graph, int recent_last,
                                       SparseCholesky* chol);
  // θ ← θ ⊞ Δ for every variable; errors (changing nothing) when a value is not finite.
  Status moveLinearizationPoint();
  void startBackgroundBatch(const std::vector<FactorId>& removed,
                            std::vector<FactorId>* live_factors);
  Status swapInBackgroundBatch(UpdateResult* result);
  void dropBackgroundBatch();

  Status incrementalStep(const std::vector<FactorId>& new_ids, UpdateResult* result);
  Status solveGaussNewton(const std::vector<char>& dirty, UpdateResult* result);
  Status solveDogLeg(UpdateResult* result, bool from_batch);
  Values valuesAt(const Eigen::VectorXd& step) const;
  std::vector<PoseValue> retractedAt(const Eigen::VectorXd& step) const;

  IncrementalOptions options_;
  PoseGraph graph_;  // values = linearisation point θ
  SquareRootFactor R_;
  SparseCholesky chol_;
  Eigen::VectorXd delta_;  // Δ, stacked by R_ positions
  std::vector<int> position_of_;
  std::vector<int> variable_at_;
  int updates_ = 0;
  bool need_batch_ = true;
  // Dog leg.
  double radius_ = 1.0;
  double cost_at_linpoint_ = 0.0;  // Σρ at θ
  std::optional<BackgroundBatch> job_;
  SquareRootFactor retired_;  // replaced at the last swap, freed by the next worker
};

}  // namespace evermap::solver
