#include "core/solver/batch_solver.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "core/common/enum_names.h"
#include "core/solver/normal_equations.h"
#include "core/solver/ordering.h"
#include "core/solver/sparse_cholesky.h"

namespace evermap::solver {

const char* methodName(Method m) {
  static constexpr EnumNames<Method, 3> kNames{{
      {Method::kGaussNewton, "gauss-newton"},
      {Method::kLevenbergMarquardt, "levenberg-marquardt"},
      {Method::kDogLeg, "dogleg"},
  }};
  return nameOf(kNames, m);
}

const char* terminationName(Termination t) {
  static constexpr EnumNames<Termination, 5> kNames{{
      {Termination::kConverged, "converged (relative decrease)"},
      {Termination::kSmallGradient, "converged (gradient)"},
      {Termination::kSmallStep, "converged (small step)"},
      {Termination::kMaxIterations, "NOT converged: iteration budget exhausted"},
      {Termination::kFailure, "failure"},
  }};
  return nameOf(kNames, t);
}

Status BatchOptions::validate() const {
  if (max_iterations < 1) return makeError("BatchOptions: max_iterations must be >= 1");
  if (!(relative_cost_tolerance >= 0.0)) {
    return makeError("BatchOptions: relative_cost_tolerance must be >= 0");
  }
  if (!(step_tolerance >= 0.0)) return makeError("BatchOptions: step_tolerance must be >= 0");
  if (!(gradient_tolerance >= 0.0)) {
    return makeError("BatchOptions: gradient_tolerance must be >= 0");
  }
  if (!(lm_initial_lambda > 0.0) || !(lm_lambda_factor > 1.0)) {
    return makeError("BatchOptions: LM needs lambda > 0 and lambda factor > 1");
  }
  if (!(initial_trust_radius > 0.0)) {
    return makeError("BatchOptions: initial_trust_radius must be > 0");
  }
  return Ok{};
}

namespace {

Values retracted(const Values& x, const Eigen::VectorXd& delta) {
  Values out = x;
  out.retractAll(delta);
  return out;
}

}  // namespace

Eigen::VectorXd dogLegStep(const Eigen::VectorXd& h_gn, const Eigen::VectorXd& h_sd,
                           double radius) {
  if (h_gn.norm() <= radius) return h_gn;
  const double sd_norm = h_sd.norm();
  if (sd_norm >= radius) return (radius / sd_norm) * h_sd;
  // β with ‖h_sd + β (h_gn − h_sd)‖ = Δ.
  const Eigen::VectorXd d = h_gn - h_sd;
  const double c = h_sd.dot(d);
  const double dd = d.squaredNorm();
  const double r2 = radius * radius - h_sd.squaredNorm();
  const double root = std::sqrt(c * c + dd * r2);
  const double beta = c <= 0.0 ? (-c + root) / dd : r2 / (c + root);
  return h_sd + beta * d;
}

namespace {

enum class Next {
  kGo,     // on with this iteration
  kRetry,  // to the next iteration (LM with a larger λ, dog leg with a smaller Δ)
  kStop,   // done: summary.termination says why
};

// The iterations of one batch solve: the linearisation point x, its gradient g and the
// factor, and the step control (λ for Levenberg-Marquardt, the trust radius Δ for dog leg).
class BatchIterations {
 public:
  BatchIterations(PoseGraph& graph, const BatchOptions& options, BatchSummary* summary)
      : graph_(graph),
        options_(options),
        summary_(*summary),
        pattern_(buildPattern(graph)),
        lambda_(options.lm_initial_lambda),
        radius_(options.initial_trust_radius) {
    const std::vector<int> order =
        fillReducingOrder(graph.values().size(), activeFactorVariables(graph));
    chol_.analyze(pattern_, order);
    x_ = graph.values();
    cost_ = assembleNormalEquations(graph_, x_, pattern_, chol_.values(), &g_);
    summary_.initial_cost = cost_.robust;
    diag_.resize(pattern_.scalarSize());
    summary_.termination = Termination::kMaxIterations;
  }

  void iterate() {
    for (int it = 0; it < options_.max_iterations; ++it) {
      const Next next = factorize(it);
      if (next == Next::kRetry) continue;
      if (next == Next::kStop) break;
      if (tryStep(it) == Next::kStop) break;
    }
  }

  // Writes the solution into the graph and completes the summary.
  void finish();

 private:
  // The factor of the (damped) normal equations at x, and the gradient test.
  Next factorize(int it);
  // The step from the factor (Gauss-Newton, or dog leg within Δ) and, for dog leg, the
  // decrease the linear model predicts for it.
  Eigen::VectorXd step(double* predicted);
  // Tries the step: a new x when it is accepted, and the convergence tests there.
  Next tryStep(int it);
  // Updates λ or Δ from the cost decrease; whether the step is taken.
  bool accept(double decrease, double predicted, const Eigen::VectorXd& step);

  double linearModelDecrease(const Eigen::VectorXd& h) {
    // L(0) − L(h) = 2 hᵀg − hᵀHh for L(h) = ‖A h − b‖².
    Eigen::VectorXd Hh = Eigen::VectorXd::Zero(h.size());
    pattern_.multiplyAdd(chol_.values(), h, &Hh);
    return 2.0 * h.dot(g_) - h.dot(Hh);
  }

  PoseGraph& graph_;
  const BatchOptions& options_;
  BatchSummary& summary_;
  const BlockPattern pattern_;
  SparseCholesky chol_;
  Values x_;
  Eigen::VectorXd g_;
  Cost cost_;
  double lambda_;
  double radius_;
  Eigen::VectorXd diag_;
  bool need_factorization_ = true;
  bool converged_ = false;
};

Next BatchIterations::factorize(int it) {
  if (options_.method == Method::kLevenbergMarquardt) {
    const auto& cp = pattern_.colPtr();
    for (int j = 0; j < pattern_.scalarSize(); ++j) {
      diag_[j] = lambda_ * std::max(chol_.values()[cp[j + 1] - 1], 1e-12);
    }
    if (auto st = chol_.factorize(diag_); !st.ok()) {
      lambda_ *= options_.lm_lambda_factor;
      ++summary_.factorizations;
      summary_.iterations = it + 1;
      return Next::kRetry;
    }
  } else if (need_factorization_) {
    if (auto st = chol_.factorize(); !st.ok()) {
      summary_.termination = Termination::kFailure;
      summary_.message = st.error().message;
      return Next::kStop;
    }
  }
  ++summary_.factorizations;
  // g is the gradient at x whenever x changed (assembled with the normal equations); the
  // test comes after the factorisation so that a singular system is still reported.
  if (need_factorization_ && g_.lpNorm<Eigen::Infinity>() <= options_.gradient_tolerance) {
    summary_.termination = Termination::kSmallGradient;
    converged_ = true;
    return Next::kStop;
  }
  summary_.iterations = it + 1;
  need_factorization_ = false;
  return Next::kGo;
}

Eigen::VectorXd BatchIterations::step(double* predicted) {
  const Eigen::VectorXd h_gn = chol_.solve(g_);
  *predicted = 0.0;
  if (options_.method != Method::kDogLeg) return h_gn;
  Eigen::VectorXd Hg = Eigen::VectorXd::Zero(g_.size());
  pattern_.multiplyAdd(chol_.values(), g_, &Hg);
  const double gHg = g_.dot(Hg);
  const Eigen::VectorXd h_sd = gHg > 0.0 ? Eigen::VectorXd((g_.squaredNorm() / gHg) * g_)
                                         : Eigen::VectorXd(Eigen::VectorXd::Zero(g_.size()));
  const Eigen::VectorXd h = dogLegStep(h_gn, h_sd, radius_);
  *predicted = linearModelDecrease(h);
  return h;
}

bool BatchIterations::accept(double decrease, double predicted, const Eigen::VectorXd& step) {
  if (options_.method == Method::kLevenbergMarquardt) {
    const bool better = decrease > 0.0;
    lambda_ = better ? lambda_ / options_.lm_lambda_factor : lambda_ * options_.lm_lambda_factor;
    return better;
  }
  if (options_.method == Method::kDogLeg) {
    const double rho = predicted > 0.0 ? decrease / predicted : -1.0;
    if (rho < 0.25) radius_ /= 2.0;
    if (rho > 0.75) radius_ = std::max(radius_, 3.0 * step.norm());
    return rho > 0.0;
  }
  return true;
}

Next BatchIterations::tryStep(int it) {
  double predicted = 0.0;
  const Eigen::VectorXd h = step(&predicted);
  const double step_max = h.lpNorm<Eigen::Infinity>();
  const Values candidate = retracted(x_, h);
  const Cost new_cost = graph_.cost(candidate);
  const bool finite = std::isfinite(new_cost.robust);
  const double decrease =
      finite ? cost_.robust - new_cost.robust : -std::numeric_limits<double>::infinity();
  if (!finite && options_.method == Method::kGaussNewton) {
    summary_.termination = Termination::kFailure;
    summary_.message = "gauss-newton diverged (non-finite cost); try lm or dogleg";
    return Next::kStop;
  }
  if (options_.verbose) {
    std::fprintf(stderr, "  iter %d: cost %.9g -> %.9g |step| %.3g%s\n", it + 1, cost_.robust,
                 new_cost.robust, step_max,
                 options_.method == Method::kDogLeg ? (" radius " + std::to_string(radius_)).c_str()
                 : options_.method == Method::kLevenbergMarquardt
                     ? (" lambda " + std::to_string(lambda_)).c_str()
                     : "");
  }
  if (!accept(decrease, predicted, h)) {
    if (step_max < options_.step_tolerance) {
      summary_.termination = Termination::kSmallStep;
      return Next::kStop;
    }
    return Next::kRetry;  // LM re-factors with the new λ; dog leg re-uses the factor with a smaller
                          // Δ
  }
  x_ = candidate;
  const double old_cost = cost_.robust;
  cost_ = assembleNormalEquations(graph_, x_, pattern_, chol_.values(), &g_);
  need_factorization_ = true;
  summary_.last_relative_decrease =
      old_cost > 0.0 ? std::abs(old_cost - cost_.robust) / old_cost : 0.0;
  if (std::abs(old_cost - cost_.robust) <= options_.relative_cost_tolerance * old_cost) {
    summary_.termination = Termination::kConverged;
    converged_ = true;
    return Next::kStop;
  }
  if (step_max < options_.step_tolerance) {
    summary_.termination = Termination::kSmallStep;
    converged_ = true;
    return Next::kStop;
  }
  return Next::kGo;
}

void BatchIterations::finish() {
  // The budget ran out; the last iteration's step may still have met a test at its end.
  if (!converged_ && summary_.termination == Termination::kMaxIterations && need_factorization_ &&
      g_.lpNorm<Eigen::Infinity>() <= options_.gradient_tolerance) {
    summary_.termination = Termination::kSmallGradient;
  }
  summary_.final_gradient_max = g_.lpNorm<Eigen::Infinity>();
  graph_.mutableValues() = x_;
  const Cost final_cost = graph_.cost();
  summary_.final_cost = final_cost.robust;
  summary_.final_weighted_sse = final_cost.weighted_sse;
  summary_.factor_nnz = chol_.factorNnz();
  if (summary_.message.empty()) {
    summary_.message = std::string(methodName(options_.method)) + ": " +
                       terminationName(summary_.termination) + " after " +
                       std::to_string(summary_.iterations) + " iterations";
  }
}

}  // namespace

BatchSummary solveBatch(PoseGraph& graph, const BatchOptions& options) {
  BatchSummary summary;
  if (auto st = options.validate(); !st.ok()) {
    summary.message = st.error().message;
    return summary;
  }
  BatchIterations iterations(graph, options, &summary);
  iterations.iterate();
  iterations.finish();
  return summary;
}

}  // namespace evermap::solver
