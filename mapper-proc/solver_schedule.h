#pragma once
// When the mapper's changes reach the solver: Algorithm 1's "update the solution", at the end
// of each step (and of a restore), through iSAM's schedule (an incremental update; every
// batch_every-th a batch step, computed in the background and swapped in later,
// MapperOptions::solver).
//
// A step's new nodes and factors are gathered and sent as one update (flush). A constraint
// that merges into a pair the solver already holds a factor of waits, when defer_merges, for
// the pair's consolidation: at the solver's scheduled batch steps (which re-factor anyway, so
// the removals cost nothing extra) the pair's factors are replaced by the one merged
// constraint of the set (paper section III-B.3). A map that no longer changes has few
// updates: there, batch_every deferred merges trigger the consolidation.

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <utility>
#include <vector>

#include "core/geometry/se3.h"
#include "core/solver/incremental_solver.h"
#include "core/solver/pose_factors.h"
#include "mapper-proc/constraint_set.h"

namespace evermap::mapper {

using NodePair = std::pair<int64_t, int64_t>;  // (i, j), i < j, as ConstraintSet keys pairs

// The factor of a relative-pose constraint i_T_j (covariance_floor added to its covariance).
std::shared_ptr<solver::RelativePose3Factor> pairFactor(int64_t i, int64_t j,
                                                        const core::UncertainPose& i_T_j,
                                                        double covariance_floor);

class SolverSchedule {
 public:
  SolverSchedule(const solver::IncrementalOptions& options, bool defer_merges,
                 double covariance_floor);

  const solver::IncrementalSolver& solver() const { return *solver_; }
  core::SE3d pose(int64_t id) const { return solver_->estimate(id).se3; }
  // Node pairs the solver holds factors for.
  int64_t factors() const { return static_cast<int64_t>(pair_factor_.size()); }

  void addVariable(int64_t id, const core::SE3d& world_T_node);
  // A factor of no node pair (the origin's prior, a height or roll/pitch factor).
  void addFactor(solver::FactorPtr factor);
  // The factor of one constraint of pair `pair`.
  void addPairFactor(const NodePair& pair, solver::FactorPtr factor);
  // A constraint merged into `pair`: the pair is consolidated at the next scheduled batch
  // step. True when the constraint gets no factor of its own now (defer_merges, and the
  // solver already holds one of the pair).
  bool deferMerge(const NodePair& pair);

  // One update sent to the solver: its time as the step would see it in operation (a
  // background batch's wait counts only beyond the message time it had; docs/mapper.md, "Step
  // cost") and what it changed.
  struct Flush {
    double solver_s = 0.0;
    bool batch = false;                // a synchronous batch step: every estimate moved
    bool batch_swapped = false;        // a background batch step swapped in
    double batch_compute_s = 0.0;      // ... the worker's time on it
    double batch_wait_s = 0.0;         // ... how long this update waited for it (offline)
    double wait_in_operation_s = 0.0;  // ... and how long a step would wait in operation
    std::vector<int64_t> added;        // the nodes of this update
  };
  // Sends what the step gathered (consolidating merged pairs at scheduled batch steps);
  // nothing to send: no update. step_utime is the message time of the step.
  std::optional<Flush> flush(int64_t step_utime, const ConstraintSet& constraints);
  // Drops what was gathered and not sent, merges waiting for consolidation included (a
  // restore that failed half-way).
  void discard();

 private:
  void consolidatePairs(const ConstraintSet& constraints);

  int batch_every_;  // the solver's batch step schedule (IncrementalOptions::batch_every)
  bool defer_merges_;
  double covariance_floor_;
  std::unique_ptr<solver::IncrementalSolver> solver_;
  solver::UpdateRequest pending_update_;
  // The solver's factors of each node pair: one, or one per agreeing constraint until the
  // pair is consolidated into its merged constraint.
  std::map<NodePair, std::vector<solver::FactorId>> pair_factor_;
  std::set<NodePair> to_consolidate_;
  int64_t deferred_merges_ = 0;  // merges waiting for consolidation without a factor of their own
  int64_t solver_updates_ = 0;
  // For each factor of pending_update_: its pair ((-1, -1) for factors of no pair) and its
  // slot in new_factors.
  std::vector<NodePair> pending_pairs_;
  std::vector<size_t> pending_factor_slot_;
  int64_t batch_start_utime_ = -1;  // message time of the step that started a background batch
};

}  // namespace evermap::mapper
