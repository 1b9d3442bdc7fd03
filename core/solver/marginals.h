#pragma once
// Exact marginal covariances of chosen variables, on demand, from the square-root factor:
// Σ = (RᵀR)⁻¹ in the tangent space of the linearisation point (the retraction of
// core/solver/values.h: (υ, ω) in each pose's own frame).
//
// For a variable k, Y_k = R⁻ᵀ E_k is non-zero only on the elimination-tree path from k's
// position to the root, so one forward substitution along that path gives it; then
// Σ_ab = Y_aᵀ Y_b for any pair (Kaess & Dellaert, "Covariance recovery from a square root
// information matrix for data association", RAS 2009, compute the same entries by a
// recursion over R; the path solve is the column form of it).

#include <map>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "core/common/expected.h"
#include "core/solver/incremental_solver.h"
#include "core/solver/pose_graph.h"
#include "core/solver/square_root_factor.h"

namespace evermap::solver {

class Marginals {
 public:
  // From the incremental solver's current factor (linearised at its θ): a copy of R, O(nnz).
  static Marginals fromSolver(const IncrementalSolver& solver);
  // The joint covariance of `keys` straight from the solver's current factor, without the
  // copy: the work is the path solves alone (the elimination-tree paths of the keys to the
  // root), not the size of R. For callers that ask a few marginals between updates.
  static Expected<Eigen::MatrixXd> jointOf(const IncrementalSolver& solver,
                                           std::span<const Key> keys);
  // Linearises the graph at its values and factors it (CHOLMOD), for batch results.
  static Expected<Marginals> compute(const PoseGraph& graph);

  // Covariance of one variable (dim × dim).
  Expected<Eigen::MatrixXd> marginal(Key key) const;
  // Joint covariance of several variables, stacked in the given order.
  Expected<Eigen::MatrixXd> joint(std::span<const Key> keys) const;

 private:
  // Blocks of at most 6 × 6 (SquareRootFactor::kMaxBlockDim) live on the stack.
  using Block = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0,
                              SquareRootFactor::kMaxBlockDim, SquareRootFactor::kMaxBlockDim>;
  using Path = std::map<int, Block>;  // position -> rows of Y at that position
  static Expected<Path> pathSolve(const SquareRootFactor& R, int position);
  static Expected<Eigen::MatrixXd> jointAt(const SquareRootFactor& R,
                                           std::span<const int> positions);

  SquareRootFactor R_;
  std::map<Key, int> position_of_key_;
};

}  // namespace evermap::solver
