#include "core/solver/gnc.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

namespace evermap::solver {

Status GncOptions::validate() const {
  if (auto st = final_stage.validate(); !st.ok()) return st;
  if (stage_max_iterations < 1) return makeError("GncOptions: stage_max_iterations must be >= 1");
  if (!(mu_factor > 1.0)) return makeError("GncOptions: mu_factor must be > 1");
  if (max_stages < 1) return makeError("GncOptions: max_stages must be >= 1");
  if (!(binary_tolerance > 0.0)) return makeError("GncOptions: binary_tolerance must be > 0");
  return Ok{};
}

namespace {

void setMu(PoseGraph& graph, const std::vector<FactorId>& ids, double mu) {
  for (FactorId id : ids) {
    RobustKernel k = graph.factor(id).kernel();
    k.gnc_mu = mu;
    graph.factorPtr(id)->setKernel(k);
  }
}

// The squared whitened error s of a factor at the graph's values.
double squaredError(const PoseGraph& graph, FactorId id) {
  return graph.cost(graph.values(), id).weighted_sse;
}

}  // namespace

GncSummary solveGnc(PoseGraph& graph, const GncOptions& options) {
  GncSummary out;
  if (auto st = options.validate(); !st.ok()) {
    out.batch.message = st.error().message;
    return out;
  }
  std::vector<FactorId> ids;
  double mu = std::numeric_limits<double>::infinity();
  for (FactorId id = 0; id < graph.numFactorSlots(); ++id) {
    if (!graph.isActive(id) || graph.factor(id).kernel().type != KernelType::kGncTls) continue;
    ids.push_back(id);
    const double c2 = graph.factor(id).kernel().parameter;
    // μ at which this factor's error lies inside the convex part (eq. (10)): 2s − c̄² > 0.
    const double s = squaredError(graph, id);
    if (2.0 * s > c2) mu = std::min(mu, c2 / (2.0 * s - c2));
  }
  out.candidates = static_cast<int>(ids.size());
  int iterations = 0;
  if (std::isfinite(mu)) {
    BatchOptions stage = options.final_stage;
    stage.max_iterations = options.stage_max_iterations;
    stage.relative_cost_tolerance = options.stage_relative_tolerance;
    for (; out.stages < options.max_stages; ++out.stages) {
      setMu(graph, ids, mu);
      const BatchSummary s = solveBatch(graph, stage);
      iterations += s.iterations;
      if (!s.ok()) {
        out.batch = s;
        out.batch.iterations = iterations;
        out.final_mu = mu;
        return out;
      }
      double most_fractional = 0.0;
      for (FactorId id : ids) {
        const double w = graph.factor(id).kernel().weight(squaredError(graph, id));
        most_fractional = std::max(most_fractional, w * (1.0 - w));
      }
      if (options.final_stage.verbose) {
        std::fprintf(stderr, "gnc stage %d: mu %.3g, %d iterations, cost %.9g, max w(1-w) %.3g\n",
                     out.stages, mu, s.iterations, s.final_cost, most_fractional);
      }
      if (most_fractional < options.binary_tolerance) break;
      mu *= options.mu_factor;
    }
  } else {
    mu = 1e6;  // every candidate already within c̄²/2: the surrogate is TLS-like wherever needed
  }
  setMu(graph, ids, mu);
  out.batch = solveBatch(graph, options.final_stage);
  out.batch.iterations += iterations;
  out.final_mu = mu;
  for (FactorId id : ids) {
    out.rejected += graph.factor(id).kernel().weight(squaredError(graph, id)) < 0.5;
  }
  return out;
}

}  // namespace evermap::solver
