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

Expected<Eigen::MatrixXd> Marginals::jointOf(const IncrementalSolver& solver,
                                             std::span<const Key> keys) {
  std::vector<int> positions;
  for (Key k : keys) {
    const int v = solver.graph().values().indexOf(k);
    if (v < 0) return makeError("marginals: unknown variable ", k);
    positions.push_back(solver.positionOf(v));
  }
  return jointAt(solver.squareRoot(), positions);
}

Expected<Marginals::Path> Marginals::pathSolve(const SquareRootFactor& R, int k) {
  const int dk = R.dimAt(k);
  // Forward substitution Rᵀ Y = E_k: rows of Y are produced in increasing position order,
  // and each only feeds positions further up the same path.
  Path pending;
  pending[k] = Block::Identity(dk, dk);
  Path Y;
  while (!pending.empty()) {
    auto node = pending.begin();
    const int p = node->first;
    const Block y = node->second;
    pending.erase(node);
    const auto& row = R.row(p);
    if (!row.initialized) return makeError("marginals: variable at position ", p, " has no factor");
    const int d = row.dim;
    // y_p = R_ppᵀ⁻¹ acc_p (lower-triangular solve).
    const Block Rpp = row.A.block(0, 0, d, d);
    const Block yp = Rpp.transpose().triangularView<Eigen::Lower>().solve(y);
    for (size_t c = 1; c < row.cols.size(); ++c) {
      const int w = row.offsets[c + 1] - row.offsets[c];
      auto [slot, inserted] = pending.try_emplace(row.cols[c], Block::Zero(w, dk));
      slot->second.noalias() -= row.A.block(0, row.offsets[c], d, w).transpose() * yp;
    }
    Y.emplace(p, yp);
  }
  return Y;
}

Expected<Eigen::MatrixXd> Marginals::marginal(Key key) const {
  const Key keys[1] = {key};
  return joint(keys);
}

Expected<Eigen::MatrixXd> Marginals::joint(std::span<const Key> keys) const {
  std::vector<int> positions;
  for (Key k : keys) {
    const auto it = position_of_key_.find(k);
    if (it == position_of_key_.end()) return makeError("marginals: unknown variable ", k);
    positions.push_back(it->second);
  }
  return jointAt(R_, positions);
}

Expected<Eigen::MatrixXd> Marginals::jointAt(const SquareRootFactor& R,
                                             std::span<const int> positions) {
  std::vector<Path> paths;
  std::vector<int> offsets = {0};
  for (int k : positions) {
    auto y = pathSolve(R, k);
    if (!y.ok()) return y.error();
    offsets.push_back(offsets.back() + static_cast<int>(y->begin()->second.cols()));
    paths.push_back(std::move(*y));
  }
  Eigen::MatrixXd S = Eigen::MatrixXd::Zero(offsets.back(), offsets.back());
  for (size_t a = 0; a < paths.size(); ++a) {
    for (size_t b = a; b < paths.size(); ++b) {
      Block block = Block::Zero(offsets[a + 1] - offsets[a], offsets[b + 1] - offsets[b]);
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
