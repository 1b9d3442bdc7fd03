#include "core/solver/normal_equations.h"

#include <algorithm>

namespace evermap::solver {

BlockPattern buildPattern(const PoseGraph& graph) {
  const Values& values = graph.values();
  std::vector<int> dims(values.size());
  for (int v = 0; v < values.size(); ++v) dims[v] = values.at(v).dim();
  std::vector<std::pair<int, int>> pairs;
  for (FactorId id = 0; id < graph.numFactorSlots(); ++id) {
    if (!graph.isActive(id)) continue;
    const auto vars = graph.variablesOf(id);
    for (size_t a = 0; a < vars.size(); ++a) {
      for (size_t b = a + 1; b < vars.size(); ++b) pairs.emplace_back(vars[a], vars[b]);
    }
  }
  return BlockPattern(std::move(dims), std::move(pairs));
}

std::vector<std::vector<int>> activeFactorVariables(const PoseGraph& graph) {
  std::vector<std::vector<int>> out;
  out.reserve(graph.numActiveFactors());
  for (FactorId id = 0; id < graph.numFactorSlots(); ++id) {
    if (!graph.isActive(id)) continue;
    const auto vars = graph.variablesOf(id);
    out.emplace_back(vars.begin(), vars.end());
  }
  return out;
}

Cost assembleNormalEquations(const PoseGraph& graph, const Values& at, const BlockPattern& pattern,
                             double* H, Eigen::VectorXd* g) {
  std::fill_n(H, pattern.nnz(), 0.0);
  g->setZero(pattern.scalarSize());
  Cost cost;
  LinearizedFactor lin;
  Eigen::MatrixXd block;
  for (FactorId id = 0; id < graph.numFactorSlots(); ++id) {
    if (!graph.isActive(id)) continue;
    linearize(graph, at, id, &lin);
    cost.robust += lin.robust_cost;
    cost.weighted_sse += lin.weighted_sse;
    cost.residual_dim += lin.b.size();
    const auto vars = graph.variablesOf(id);
    int col_a = 0;
    for (size_t a = 0; a < vars.size(); ++a) {
      const int va = vars[a];
      const int da = pattern.dim(va);
      const auto Aa = lin.A.middleCols(col_a, da);
      g->segment(pattern.offset(va), da).noalias() += Aa.transpose() * lin.b;
      int col_b = 0;
      for (size_t b = 0; b < vars.size(); ++b) {
        const int vb = vars[b];
        const int db = pattern.dim(vb);
        if (va <= vb) {
          block.noalias() = Aa.transpose() * lin.A.middleCols(col_b, db);
          pattern.addBlock(va, vb, block, H);
        }
        col_b += db;
      }
      col_a += da;
    }
  }
  return cost;
}

}  // namespace evermap::solver
