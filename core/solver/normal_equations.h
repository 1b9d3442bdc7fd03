#pragma once
// Assembly of the normal equations H δ = g (H = AᵀA, g = Aᵀb over the linearised,
// whitened, reweighted factors) into a CHOLMOD block pattern; shared by the batch solver and
// the incremental solver's batch steps.

#include <vector>

#include <Eigen/Core>

#include "core/solver/pose_graph.h"
#include "core/solver/sparse_cholesky.h"

namespace evermap::solver {

// Block structure of H for the graph's active factors (blocks = variables, natural order).
BlockPattern buildPattern(const PoseGraph& graph);
// Variables of each active factor (for the ordering).
std::vector<std::vector<int>> activeFactorVariables(const PoseGraph& graph);

// Fills H (values of `pattern`, zeroed first) and g at `at`; returns the cost there.
Cost assembleNormalEquations(const PoseGraph& graph, const Values& at, const BlockPattern& pattern,
                             double* H, Eigen::VectorXd* g);

}  // namespace evermap::solver
