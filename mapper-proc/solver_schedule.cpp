#include "mapper-proc/solver_schedule.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>

#include <Eigen/Cholesky>

#include "core/common/clocks.h"

namespace evermap::mapper {
namespace {

Eigen::MatrixXd sqrtInformation(const core::Mat6& covariance, double floor) {
  const core::Mat6 c = covariance + floor * core::Mat6::Identity();
  // Upper-triangular W with WᵀW = Σ⁻¹: the transposed Cholesky factor of the information.
  const core::Mat6 info = c.ldlt().solve(core::Mat6::Identity());
  const core::Mat6 sym = 0.5 * (info + info.transpose());
  Eigen::LLT<core::Mat6> llt(sym);
  return Eigen::MatrixXd(llt.matrixU());
}

}  // namespace

std::shared_ptr<solver::RelativePose3Factor> pairFactor(int64_t i, int64_t j,
                                                        const core::UncertainPose& i_T_j,
                                                        double covariance_floor) {
  return std::make_shared<solver::RelativePose3Factor>(
      i, j, i_T_j.mean, sqrtInformation(i_T_j.covariance, covariance_floor),
      solver::RelativePose3Factor::Convention::kLog);
}

SolverSchedule::SolverSchedule(const solver::IncrementalOptions& options, bool defer_merges,
                               double covariance_floor)
    : batch_every_(options.batch_every),
      defer_merges_(defer_merges),
      covariance_floor_(covariance_floor),
      solver_(std::make_unique<solver::IncrementalSolver>(options)) {}

void SolverSchedule::addVariable(int64_t id, const core::SE3d& world_T_node) {
  pending_update_.new_variables.emplace_back(id, solver::PoseValue::spatial(world_T_node));
}

void SolverSchedule::addFactor(solver::FactorPtr factor) {
  pending_update_.new_factors.push_back(std::move(factor));
  pending_pairs_.emplace_back(-1, -1);
  pending_factor_slot_.push_back(pending_update_.new_factors.size() - 1);
}

void SolverSchedule::addPairFactor(const NodePair& pair, solver::FactorPtr factor) {
  pending_pairs_.push_back(pair);
  pending_factor_slot_.push_back(pending_update_.new_factors.size());
  pending_update_.new_factors.push_back(std::move(factor));
}

bool SolverSchedule::deferMerge(const NodePair& pair) {
  to_consolidate_.insert(pair);
  // A pair the solver already holds a factor of: the merge refines it, and waits for the
  // next consolidation instead of an incremental update now (on a map that has stopped
  // growing most constraints are such refinements, and each update's cost grows with the
  // elimination path of the pair).
  if (defer_merges_ && pair_factor_.count(pair)) {
    ++deferred_merges_;
    return true;
  }
  return false;
}

void SolverSchedule::consolidatePairs(const ConstraintSet& constraints) {
  // Pairs with several factors, none of them still waiting in this update: their factors
  // are replaced by the one merged constraint of the set (paper section III-B.3: redundant
  // constraints combined once they agree).
  std::set<NodePair> waiting(pending_pairs_.begin(), pending_pairs_.end());
  for (auto it = to_consolidate_.begin(); it != to_consolidate_.end();) {
    auto factors = pair_factor_.find(*it);
    if (waiting.count(*it) || factors == pair_factor_.end()) {
      ++it;
      continue;
    }
    const ConstraintSet::Pair& pair = constraints.pairs().at(*it);
    for (solver::FactorId id : factors->second) pending_update_.remove_factors.push_back(id);
    pair_factor_.erase(factors);
    addPairFactor(*it, pairFactor(pair.i, pair.j, pair.i_T_j, covariance_floor_));
    it = to_consolidate_.erase(it);
  }
}

std::optional<SolverSchedule::Flush> SolverSchedule::flush(int64_t step_utime,
                                                           const ConstraintSet& constraints) {
  // Merged pairs are consolidated at the solver's scheduled batch steps: it batch-steps every
  // batch_every-th update anyway (its update counter starts at 0).
  const auto t0 = SteadyClock::now();
  const int every = batch_every_;
  const bool changes =
      !pending_update_.new_variables.empty() || !pending_update_.new_factors.empty();
  const bool scheduled = every > 0 && changes && solver_updates_ % every == 0;
  const bool idle = every > 0 && !changes && deferred_merges_ >= every;
  if ((scheduled || idle) && !to_consolidate_.empty()) {
    consolidatePairs(constraints);
    deferred_merges_ = 0;
  }
  if (!changes && pending_update_.remove_factors.empty()) return std::nullopt;
  ++solver_updates_;
  auto result = solver_->update(pending_update_);
  Flush out;
  out.solver_s = secondsSince(t0);
  // Contract: the mapper only builds updates over keys it created, with finite factors.
  if (!result) {
    std::fprintf(stderr, "evermap-mapper: solver update failed: %s\n",
                 result.error().message.c_str());
    std::abort();
  }
  if (result->batch_started) batch_start_utime_ = step_utime;
  if (result->batch_swapped) {
    // The worker had the message time since the start to finish; in operation the step
    // waits only for what it needed beyond that. The offline runner's own wait (message
    // time compressed ~2000x) is counted apart, and the worker's time too.
    const double given_s = 1e-6 * static_cast<double>(step_utime - batch_start_utime_);
    out.wait_in_operation_s = std::max(0.0, result->batch_compute_s - given_s);
    out.solver_s += out.wait_in_operation_s - result->batch_wait_s;
    out.batch_compute_s = result->batch_compute_s;
    out.batch_wait_s = result->batch_wait_s;
  }
  out.batch = result->batch;
  out.batch_swapped = result->batch_swapped;
  for (size_t k = 0; k < pending_pairs_.size(); ++k)
    if (pending_pairs_[k].first >= 0)
      pair_factor_[pending_pairs_[k]].push_back(result->new_factor_ids[pending_factor_slot_[k]]);
  for (const auto& [key, value] : pending_update_.new_variables) out.added.push_back(key);
  pending_update_ = {};
  pending_pairs_.clear();
  pending_factor_slot_.clear();
  return out;
}

void SolverSchedule::discard() {
  pending_update_ = {};
  pending_pairs_.clear();
  pending_factor_slot_.clear();
  to_consolidate_.clear();
  deferred_merges_ = 0;
}

}  // namespace evermap::mapper
