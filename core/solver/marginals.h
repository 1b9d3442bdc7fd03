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
  // From the incremental solver's current factor (linearised at its θ).
  static Marginals fromSolver(const IncrementalSolver& solver);
  // Linearises the graph at its values and factors it (CHOLMOD), for batch results.
  static Expected<Marginals> compute(const PoseGraph& graph);

  // Covariance of one variable (dim × dim).
  Expected<Eigen::MatrixXd> marginal(Key key) const;
  // Joint covariance of several variables, stacked in the given order.
  Expected<Eigen::MatrixXd> joint(std::span<const Key> keys) const;

 private:
  using Path = std::map<int, Eigen::MatrixXd>;  // position -> rows of Y at that position
  Expected<Path> pathSolve(Key key) const;

  SquareRootFactor R_;
  std::map<Key, int> position_of_key_;
};

}  // namespace evermap::solver
