#include "core/solver/marginals.h"

#include "core/solver/normal_equations.h"
#include "core/solver/ordering.h"
#include "core/solver/sparse_cholesky.h"

namespace evermap::solver {

Marginals Marginals::fromSolver(const IncrementalSolver& solver) {
  Marginals m;
  m.R_ = solver.squareRoot();
  const Values& v = solver.graph().values();
  for (int i = 0; i < v.size(); ++i) m.position_of_key_[v.keyAt(i)] = solver.positionOf(i);
  return m;
}

Expected<Marginals> Marginals::compute(const PoseGraph& graph) {
  Marginals m;
  const BlockPattern pattern = buildPattern(graph);
  SparseCholesky chol;
  chol.analyze(pattern, fillReducingOrder(graph.values().size(), activeFactorVariables(graph)));
  Eigen::VectorXd g;
  assembleNormalEquations(graph, graph.values(), pattern, chol.values(), &g);
  if (auto st = chol.factorize(); !st.ok()) return st.error();
  chol.extractSquareRoot(&m.R_);
  const auto& order = chol.blockOrder();
  for (size_t p = 0; p < order.size(); ++p) {
    m.position_of_key_[graph.values().keyAt(order[p])] = static_cast<int>(p);
  }
  return m;
}

Expected<Marginals::Path> Marginals::pathSolve(Key key) const {
  const auto it = position_of_key_.find(key);
  if (it == position_of_key_.end()) return makeError("marginals: unknown variable ", key);
  const int k = it->second;
  const int dk = R_.dimAt(k);
  // Forward substitution Rᵀ Y = E_k: rows of Y are produced in increasing position order,
  // and each only feeds positions further up the same path.
  Path pending;
  pending[k] = Eigen::MatrixXd::Identity(dk, dk);
  Path Y;
  while (!pending.empty()) {
    auto node = pending.begin();
    const int p = node->first;
    Eigen::MatrixXd y = std::move(node->second);
    pending.erase(node);
    const auto& row = R_.row(p);
    if (!row.initialized) return makeError("marginals: variable at position ", p, " has no factor");
    const int d = row.dim;
    // y_p = R_ppᵀ⁻¹ acc_p (lower-triangular solve).
    const Eigen::MatrixXd Rpp = row.A.leftCols(d);
    Eigen::MatrixXd yp = Rpp.transpose().triangularView<Eigen::Lower>().solve(y);
    for (size_t c = 1; c < row.cols.size(); ++c) {
      const int w = row.offsets[c + 1] - row.offsets[c];
      Eigen::MatrixXd contrib = row.A.middleCols(row.offsets[c], w).transpose() * yp;
      auto [slot, inserted] = pending.try_emplace(row.cols[c], Eigen::MatrixXd::Zero(w, dk));
      slot->second -= contrib;
    }
    Y.emplace(p, std::move(yp));
  }
  return Y;
}

Expected<Eigen::MatrixXd> Marginals::marginal(Key key) const {
  const Key keys[1] = {key};
  return joint(keys);
}

Expected<Eigen::MatrixXd> Marginals::joint(std::span<const Key> keys) const {
  std::vector<Path> paths;
  std::vector<int> offsets = {0};
  for (Key k : keys) {
    auto y = pathSolve(k);
    if (!y.ok()) return y.error();
    offsets.push_back(offsets.back() + static_cast<int>(y->begin()->second.cols()));
    paths.push_back(std::move(*y));
  }
  Eigen::MatrixXd S = Eigen::MatrixXd::Zero(offsets.back(), offsets.back());
  for (size_t a = 0; a < paths.size(); ++a) {
    for (size_t b = a; b < paths.size(); ++b) {
      Eigen::MatrixXd block = Eigen::MatrixXd::Zero(offsets[a + 1] - offsets[a],
                                                    offsets[b + 1] - offsets[b]);
      for (const auto& [p, ya] : paths[a]) {
        const auto yb = paths[b].find(p);
        if (yb != paths[b].end()) block.noalias() += ya.transpose() * yb->second;
      }
      S.block(offsets[a], offsets[b], block.rows(), block.cols()) = block;
      S.block(offsets[b], offsets[a], block.cols(), block.rows()) = block.transpose();
    }
  }
  return S;
}

}  // namespace evermap::solver
