#include "core/solver/pose_graph.h"

#include <array>
#include <cmath>

namespace evermap::solver {

Status PoseGraph::addVariable(Key key, const PoseValue& value) {
  if (values_.contains(key)) return makeError("variable ", key, " added twice");
  values_.add(key, value);
  return Ok{};
}

Expected<FactorId> PoseGraph::addFactor(FactorPtr factor) {
  std::vector<int> idx;
  const auto& keys = factor->keys();
  if (keys.empty() || keys.size() > 8) {
    return makeError(factor->name(), " factor: needs 1 to 8 variables, has ", keys.size());
  }
  if (factor->dim() > kMaxResidualDim) {
    return makeError(factor->name(), " factor: residual dimension ", factor->dim(), " exceeds ",
                     kMaxResidualDim);
  }
  for (size_t i = 0; i < keys.size(); ++i) {
    const int v = values_.indexOf(keys[i]);
    if (v < 0) return makeError(factor->name(), " factor: unknown variable ", keys[i]);
    if (values_.at(v).kind != factor->kindOf(static_cast<int>(i))) {
      return makeError(factor->name(), " factor: variable ", keys[i], " has the wrong pose kind");
    }
    for (int u : idx) {
      if (u == v) return makeError(factor->name(), " factor: variable ", keys[i], " used twice");
    }
    idx.push_back(v);
  }
  factors_.push_back(std::move(factor));
  vars_.push_back(std::move(idx));
  ++num_active_;
  return static_cast<FactorId>(factors_.size() - 1);
}

Status PoseGraph::removeFactor(FactorId id) {
  if (id < 0 || id >= numFactorSlots()) return makeError("factor ", id, " does not exist");
  if (!factors_[id]) return makeError("factor ", id, " was already removed");
  factors_[id].reset();
  --num_active_;
  return Ok{};
}

Cost PoseGraph::cost(const Values& at, FactorId id) const {
  return costOf(std::span<const PoseValue>(at.all()), id);
}

Cost PoseGraph::costOf(std::span<const PoseValue> at, FactorId id) const {
  Cost c;
  const Factor& f = *factors_[id];
  std::array<const PoseValue*, 8> x{};
  const auto& idx = vars_[id];
  for (size_t i = 0; i < idx.size(); ++i) x[i] = &at[idx[i]];
  double r_data[kMaxResidualDim];
  Eigen::Map<Eigen::VectorXd> r(r_data, f.dim());
  f.evaluate(std::span<const PoseValue* const>(x.data(), idx.size()), r.data(), nullptr);
  const double s = (f.sqrtInformation().triangularView<Eigen::Upper>() * r).squaredNorm();
  c.weighted_sse = s;
  c.robust = f.kernel().cost(s);
  c.residual_dim = f.dim();
  return c;
}

Cost PoseGraph::cost(std::span<const PoseValue> at) const {
  Cost total;
  for (FactorId id = 0; id < numFactorSlots(); ++id) {
    if (!factors_[id]) continue;
    const Cost c = costOf(at, id);
    total.robust += c.robust;
    total.weighted_sse += c.weighted_sse;
    total.residual_dim += c.residual_dim;
  }
  return total;
}

void linearize(const PoseGraph& graph, const Values& at, FactorId id, LinearizedFactor* out) {
  const Factor& f = graph.factor(id);
  const auto idx = graph.variablesOf(id);
  const int m = f.dim();
  std::array<const PoseValue*, 8> x{};
  std::array<double*, 8> jac{};
  int width = 0;
  for (size_t i = 0; i < idx.size(); ++i) {
    x[i] = &at.at(idx[i]);
    width += x[i]->dim();
  }
  out->A.resize(m, width);
  out->b.resize(m);
  int col = 0;
  for (size_t i = 0; i < idx.size(); ++i) {
    jac[i] = out->A.data() + static_cast<int64_t>(col) * m;  // column-major blocks
    col += x[i]->dim();
  }
  f.evaluate(std::span<const PoseValue* const>(x.data(), idx.size()), out->b.data(), jac.data());
  const auto W = f.sqrtInformation().triangularView<Eigen::Upper>();
  out->b = W * out->b;
  out->A = W * out->A;
  const double s = out->b.squaredNorm();
  out->weighted_sse = s;
  out->robust_cost = f.kernel().cost(s);
  double sqrt_w = 1.0;
  if (f.kernel().active()) sqrt_w = std::sqrt(f.kernel().weight(s));
  out->b *= -sqrt_w;
  if (sqrt_w != 1.0) out->A *= sqrt_w;
}

}  // namespace evermap::solver
