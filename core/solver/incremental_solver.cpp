#include "core/solver/incremental_solver.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <set>

#include "core/solver/normal_equations.h"
#include "core/solver/ordering.h"

namespace evermap::solver {

Status IncrementalOptions::validate() const {
  if (method == Method::kLevenbergMarquardt) {
    return makeError("IncrementalOptions: Levenberg-Marquardt has no incremental mode "
                     "(use gn or dogleg)");
  }
  if (batch_every < 0) return makeError("IncrementalOptions: batch_every must be >= 0");
  if (recent_last < 0) return makeError("IncrementalOptions: recent_last must be >= 0");
  if (!(wildfire_threshold >= 0.0)) {
    return makeError("IncrementalOptions: wildfire_threshold must be >= 0");
  }
  if (!(initial_trust_radius > 0.0)) {
    return makeError("IncrementalOptions: initial_trust_radius must be > 0");
  }
  return Ok{};
}

IncrementalSolver::IncrementalSolver(IncrementalOptions options)
    : options_(options), radius_(options.initial_trust_radius) {}

Expected<UpdateResult> IncrementalSolver::update(const UpdateRequest& request) {
  if (auto st = options_.validate(); !st.ok()) return st.error();
  // Validate everything before changing anything.
  std::set<Key> fresh;
  for (const auto& [key, value] : request.new_variables) {
    if (graph_.values().contains(key) || !fresh.insert(key).second) {
      return makeError("update: variable ", key, " already exists");
    }
  }
  auto kindOf = [&](Key k) -> int {
    for (const auto& [key, value] : request.new_variables) {
      if (key == k) return static_cast<int>(value.kind);
    }
    const int v = graph_.values().indexOf(k);
    return v < 0 ? -1 : static_cast<int>(graph_.values().at(v).kind);
  };
  for (const FactorPtr& f : request.new_factors) {
    for (size_t i = 0; i < f->keys().size(); ++i) {
      const int kind = kindOf(f->keys()[i]);
      if (kind < 0) return makeError("update: ", f->name(), " factor uses unknown variable ", f->keys()[i]);
      if (kind != static_cast<int>(f->kindOf(static_cast<int>(i)))) {
        return makeError("update: ", f->name(), " factor: variable ", f->keys()[i],
                         " has the wrong pose kind");
      }
    }
  }
  for (FactorId id : request.remove_factors) {
    if (id < 0 || id >= graph_.numFactorSlots() || !graph_.isActive(id)) {
      return makeError("update: factor ", id, " does not exist or was removed");
    }
  }

  UpdateResult result;
  for (const auto& [key, value] : request.new_variables) {
    (void)graph_.addVariable(key, value);
    variable_at_.push_back(graph_.values().size() - 1);
    position_of_.push_back(R_.appendPosition(value.dim()));
  }
  delta_.conservativeResizeLike(Eigen::VectorXd::Zero(R_.scalarSize()));
  for (const FactorPtr& f : request.new_factors) {
    auto id = graph_.addFactor(f);
    if (!id.ok()) return id.error();  // not reached: validated above
    result.new_factor_ids.push_back(*id);
  }
  for (FactorId id : request.remove_factors) (void)graph_.removeFactor(id);

  const bool scheduled = options_.batch_every > 0 && updates_ % options_.batch_every == 0;
  ++updates_;
  if (need_batch_ || request.force_batch || !request.remove_factors.empty() || scheduled) {
    result.batch = true;
    if (auto st = batchStep(); !st.ok()) return st.error();
    result.rows_solved = R_.size();
    return result;
  }
  if (auto st = incrementalStep(result.new_factor_ids, &result); !st.ok()) return st.error();
  return result;
}

Status IncrementalSolver::incrementalStep(const std::vector<FactorId>& new_ids,
                                          UpdateResult* result) {
  std::vector<char> dirty(R_.size(), 0);
  LinearizedFactor lin;
  std::vector<std::pair<int, int>> blocks;  // (position, column in lin.A)
  std::vector<int> positions;
  std::vector<int> touched;
  Eigen::MatrixXd A;
  for (FactorId id : new_ids) {
    linearize(graph_, graph_.values(), id, &lin);
    cost_at_linpoint_ += lin.robust_cost;
    const auto vars = graph_.variablesOf(id);
    blocks.clear();
    int col = 0;
    for (int v : vars) {
      blocks.emplace_back(position_of_[v], col);
      col += graph_.values().at(v).dim();
    }
    std::sort(blocks.begin(), blocks.end());
    // Columns in position order.
    A.resize(lin.A.rows(), lin.A.cols());
    positions.clear();
    int out = 0;
    for (auto [p, c] : blocks) {
      const int w = R_.dimAt(p);
      A.middleCols(out, w) = lin.A.middleCols(c, w);
      positions.push_back(p);
      out += w;
    }
    touched.clear();
    R_.addRows(positions, A, lin.b, &touched);
    for (int p : touched) {
      if (!dirty[p]) ++result->rows_modified;
      dirty[p] = 1;
    }
  }
  if (options_.method == Method::kDogLeg) return solveDogLeg(result, false);
  return solveGaussNewton(dirty, result);
}

Status IncrementalSolver::solveGaussNewton(const std::vector<char>& dirty, UpdateResult* result) {
  auto n = R_.backSubstitutePartial(dirty, options_.wildfire_threshold, &delta_);
  if (!n.ok()) return n.error();
  result->rows_solved = *n;
  return Ok{};
}

Status IncrementalSolver::solveDogLeg(UpdateResult* result, bool from_batch) {
  Eigen::VectorXd h_gn;
  if (auto st = R_.backSubstitute(&h_gn); !st.ok()) return st;
  result->rows_solved = R_.size();
  const Eigen::VectorXd d = R_.rhs();
  const Eigen::VectorXd g = R_.multiplyTranspose(d);  // −∇ of ½‖R h − d‖² at h = 0
  const double Rg2 = R_.multiply(g).squaredNorm();
  if (!(Rg2 > 0.0)) {  // at a stationary point of the linear model
    delta_.setZero(R_.scalarSize());
    return Ok{};
  }
  const Eigen::VectorXd h_sd = (g.squaredNorm() / Rg2) * g;
  const double d2 = d.squaredNorm();
  // RISE: shrink until the true cost drops (batch steps); incremental steps try once and
  // keep the last accepted step otherwise.
  for (int attempt = 0; attempt < (from_batch ? 30 : 1); ++attempt) {
    const Eigen::VectorXd h = dogLegStep(h_gn, h_sd, radius_);
    const double predicted = d2 - (R_.multiply(h) - d).squaredNorm();
    const double actual = cost_at_linpoint_ - graph_.cost(valuesAt(h)).robust;
    const double rho = predicted > 0.0 ? actual / predicted : -1.0;
    if (rho < 0.25) radius_ /= 2.0;
    if (rho > 0.75) radius_ = std::max(radius_, 3.0 * h.norm());
    if (rho > 0.0) {
      delta_ = h;
      result->step_accepted = true;
      return Ok{};
    }
    result->step_accepted = false;
    if (predicted <= 0.0 && from_batch) break;  // already at the minimum of the model
  }
  if (from_batch) delta_.setZero(R_.scalarSize());
  return Ok{};
}

Status IncrementalSolver::batchStep() {
  if (graph_.values().size() == 0) return Ok{};
  // θ ← θ ⊞ Δ in place (copying Values would rebuild its key index); checked first so
  // that a diverged estimate leaves the state untouched.
  Values& theta = graph_.mutableValues();
  for (int pass = 0; pass < 2; ++pass) {
    for (int v = 0; v < theta.size(); ++v) {
      const PoseValue p = retract(theta.at(v), delta_.data() + R_.scalarOffset(position_of_[v]));
      if (pass == 1) {
        theta.at(v) = p;
        continue;
      }
      const bool finite =
          p.kind == PoseKind::kSE2
              ? p.se2.vector().allFinite()
              : (p.se3.translation().allFinite() && p.se3.quaternion().coeffs().allFinite());
      if (!finite) {
        return makeError("the estimate diverged (variable ", theta.keyAt(v),
                         " is not finite); try --method dogleg or a robust kernel");
      }
    }
  }
  delta_.setZero(R_.scalarSize());
  const BlockPattern pattern = buildPattern(graph_);
  std::vector<int> recent;
  const int n = graph_.values().size();
  for (int v = std::max(0, n - options_.recent_last); v < n && options_.recent_last > 0; ++v) {
    recent.push_back(v);
  }
  chol_.analyze(pattern, fillReducingOrder(n, activeFactorVariables(graph_), recent));
  Eigen::VectorXd g;
  cost_at_linpoint_ =
      assembleNormalEquations(graph_, graph_.values(), pattern, chol_.values(), &g).robust;
  if (auto st = chol_.factorize(); !st.ok()) return st;
  chol_.extractSquareRoot(&R_);
  variable_at_ = chol_.blockOrder();
  for (size_t p = 0; p < variable_at_.size(); ++p) position_of_[variable_at_[p]] = static_cast<int>(p);
  // d = R⁻ᵀ P g: R ᵀR = P H Pᵀ and Rᵀ d = P Aᵀ b.
  Eigen::VectorXd g_pos(R_.scalarSize());
  for (int p = 0; p < R_.size(); ++p) {
    const int v = variable_at_[p];
    g_pos.segment(R_.scalarOffset(p), R_.dimAt(p)) = g.segment(pattern.offset(v), pattern.dim(v));
  }
  R_.setRhs(R_.solveTranspose(g_pos));
  need_batch_ = false;
  delta_.setZero(R_.scalarSize());
  if (options_.method == Method::kDogLeg) {
    UpdateResult ignored;
    return solveDogLeg(&ignored, true);
  }
  return R_.backSubstitute(&delta_);
}

BatchSummary IncrementalSolver::optimize(const BatchOptions& options) {
  graph_.mutableValues() = estimate();
  delta_.setZero(R_.scalarSize());
  BatchSummary summary = solveBatch(graph_, options);
  if (summary.ok()) {
    if (auto st = batchStep(); !st.ok()) {
      summary.termination = Termination::kFailure;
      summary.message = st.error().message;
    }
  }
  return summary;
}

Values IncrementalSolver::valuesAt(const Eigen::VectorXd& step) const {
  Values out = graph_.values();
  for (int v = 0; v < out.size(); ++v) {
    out.at(v) = retract(out.at(v), step.data() + R_.scalarOffset(position_of_[v]));
  }
  return out;
}

Values IncrementalSolver::estimate() const { return valuesAt(delta_); }

PoseValue IncrementalSolver::estimate(Key key) const {
  const int v = graph_.values().indexOf(key);
  if (v < 0) return PoseValue();
  return retract(graph_.values().at(v), delta_.data() + R_.scalarOffset(position_of_[v]));
}

Cost IncrementalSolver::cost() const { return graph_.cost(estimate()); }

}  // namespace evermap::solver
