#include "core/solver/batch_solver.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "core/solver/normal_equations.h"
#include "core/solver/ordering.h"
#include "core/solver/sparse_cholesky.h"

namespace evermap::solver {

const char* methodName(Method m) {
  switch (m) {
    case Method::kGaussNewton:
      return "gauss-newton";
    case Method::kLevenbergMarquardt:
      return "levenberg-marquardt";
    case Method::kDogLeg:
      return "dogleg";
  }
  return "?";
}

Expected<Method> parseMethod(const std::string& text) {
  if (text == "gn" || text == "gauss-newton") return Method::kGaussNewton;
  if (text == "lm" || text == "levenberg-marquardt") return Method::kLevenbergMarquardt;
  if (text == "dogleg" || text == "dl" || text == "powell") return Method::kDogLeg;
  return makeError("method '", text, "': expected gn, lm or dogleg");
}

const char* terminationName(Termination t) {
  switch (t) {
    case Termination::kConverged:
      return "converged (relative decrease)";
    case Termination::kSmallGradient:
      return "converged (gradient)";
    case Termination::kSmallStep:
      return "converged (small step)";
    case Termination::kMaxIterations:
      return "NOT converged: iteration budget exhausted";
    case Termination::kFailure:
      return "failure";
  }
  return "?";
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

BatchSummary solveBatch(PoseGraph& graph, const BatchOptions& options) {
  BatchSummary summary;
  if (auto st = options.validate(); !st.ok()) {
    summary.message = st.error().message;
    return summary;
  }
  const BlockPattern pattern = buildPattern(graph);
  const std::vector<int> order =
      fillReducingOrder(graph.values().size(), activeFactorVariables(graph));
  SparseCholesky chol;
  chol.analyze(pattern, order);

  Values x = graph.values();
  Eigen::VectorXd g;
  Cost cost = assembleNormalEquations(graph, x, pattern, chol.values(), &g);
  summary.initial_cost = cost.robust;
  double lambda = options.lm_initial_lambda;
  double radius = options.initial_trust_radius;
  Eigen::VectorXd diag(pattern.scalarSize());
  summary.termination = Termination::kMaxIterations;
  bool need_factorization = true;

  auto linearModelDecrease = [&](const Eigen::VectorXd& h) {
    // L(0) − L(h) = 2 hᵀg − hᵀHh for L(h) = ‖A h − b‖².
    Eigen::VectorXd Hh = Eigen::VectorXd::Zero(h.size());
    pattern.multiplyAdd(chol.values(), h, &Hh);
    return 2.0 * h.dot(g) - h.dot(Hh);
  };

  bool converged = false;
  for (int it = 0; it < options.max_iterations; ++it) {
    Eigen::VectorXd step;
    if (options.method == Method::kLevenbergMarquardt) {
      const auto& cp = pattern.colPtr();
      for (int j = 0; j < pattern.scalarSize(); ++j) {
        diag[j] = lambda * std::max(chol.values()[cp[j + 1] - 1], 1e-12);
      }
      if (auto st = chol.factorize(diag); !st.ok()) {
        lambda *= options.lm_lambda_factor;
        ++summary.factorizations;
        summary.iterations = it + 1;
        continue;
      }
    } else if (need_factorization) {
      if (auto st = chol.factorize(); !st.ok()) {
        summary.termination = Termination::kFailure;
        summary.message = st.error().message;
        break;
      }
    }
    ++summary.factorizations;
    // g is the gradient at x whenever x changed (assembled with the normal equations); the
    // test comes after the factorisation so that a singular system is still reported.
    if (need_factorization && g.lpNorm<Eigen::Infinity>() <= options.gradient_tolerance) {
      summary.termination = Termination::kSmallGradient;
      converged = true;
      break;
    }
    summary.iterations = it + 1;
    need_factorization = false;
    const Eigen::VectorXd h_gn = chol.solve(g);
    step = h_gn;
    double predicted = 0.0;
    if (options.method == Method::kDogLeg) {
      Eigen::VectorXd Hg = Eigen::VectorXd::Zero(g.size());
      pattern.multiplyAdd(chol.values(), g, &Hg);
      const double gHg = g.dot(Hg);
      const Eigen::VectorXd h_sd = gHg > 0.0 ? Eigen::VectorXd((g.squaredNorm() / gHg) * g)
                                             : Eigen::VectorXd(Eigen::VectorXd::Zero(g.size()));
      step = dogLegStep(h_gn, h_sd, radius);
      predicted = linearModelDecrease(step);
    }
    const double step_max = step.lpNorm<Eigen::Infinity>();
    const Values candidate = retracted(x, step);
    const Cost new_cost = graph.cost(candidate);
    const bool finite = std::isfinite(new_cost.robust);
    const double decrease =
        finite ? cost.robust - new_cost.robust : -std::numeric_limits<double>::infinity();
    if (!finite && options.method == Method::kGaussNewton) {
      summary.termination = Termination::kFailure;
      summary.message = "gauss-newton diverged (non-finite cost); try lm or dogleg";
      break;
    }
    if (options.verbose) {
      std::fprintf(stderr, "  iter %d: cost %.9g -> %.9g |step| %.3g%s\n", it + 1, cost.robust,
                   new_cost.robust, step_max,
                   options.method == Method::kDogLeg ? (" radius " + std::to_string(radius)).c_str()
                   : options.method == Method::kLevenbergMarquardt
                       ? (" lambda " + std::to_string(lambda)).c_str()
                       : "");
    }

    bool accept = true;
    if (options.method == Method::kLevenbergMarquardt) {
      accept = decrease > 0.0;
      lambda = accept ? lambda / options.lm_lambda_factor : lambda * options.lm_lambda_factor;
    } else if (options.method == Method::kDogLeg) {
      const double rho = predicted > 0.0 ? decrease / predicted : -1.0;
      if (rho < 0.25) radius /= 2.0;
      if (rho > 0.75) radius = std::max(radius, 3.0 * step.norm());
      accept = rho > 0.0;
    }
    if (!accept) {
      if (step_max < options.step_tolerance) {
        summary.termination = Termination::kSmallStep;
        break;
      }
      continue;  // LM re-factors with the new λ; dog leg re-uses the factor with a smaller Δ
    }
    x = candidate;
    const double old_cost = cost.robust;
    cost = assembleNormalEquations(graph, x, pattern, chol.values(), &g);
    need_factorization = true;
    summary.last_relative_decrease =
        old_cost > 0.0 ? std::abs(old_cost - cost.robust) / old_cost : 0.0;
    if (std::abs(old_cost - cost.robust) <= options.relative_cost_tolerance * old_cost) {
      summary.termination = Termination::kConverged;
      converged = true;
      break;
    }
    if (step_max < options.step_tolerance) {
      summary.termination = Termination::kSmallStep;
      converged = true;
      break;
    }
  }
  // The budget ran out; the last iteration's step may still have met a test at its end.
  if (!converged && summary.termination == Termination::kMaxIterations && need_factorization &&
      g.lpNorm<Eigen::Infinity>() <= options.gradient_tolerance) {
    summary.termination = Termination::kSmallGradient;
  }
  summary.final_gradient_max = g.lpNorm<Eigen::Infinity>();
  graph.mutableValues() = x;
  const Cost final_cost = graph.cost();
  summary.final_cost = final_cost.robust;
  summary.final_weighted_sse = final_cost.weighted_sse;
  summary.factor_nnz = chol.factorNnz();
  if (summary.message.empty()) {
    summary.message = std::string(methodName(options.method)) + ": " +
                      terminationName(summary.termination) + " after " +
                      std::to_string(summary.iterations) + " iterations";
  }
  return summary;
}

}  // namespace evermap::solver
