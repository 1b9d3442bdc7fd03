#pragma once
// From a pose-graph file to factors, initial values and the SE-Sync cost.
//
// Objectives:
//   kNative  — each format's own residual: iSAM's for iSAM files (so the weighted SSE is
//              iSAM's), g2o's (z⁻¹ a⁻¹ b with (t, q.xyz)) for g2o and TORO files.
//   kSeSync  — SE-Sync's isotropic chordal cost f (Rosen et al., IJRR 2019, eq. 13), with
//              κ, τ from each edge's information matrix:
//                2-D: τ = 2 / tr((I_tt)⁻¹), κ = I_θθ
//                3-D: τ = 3 / tr((I_tt)⁻¹), κ = 3 / (2 tr((I_RR)⁻¹))
//              f = Σ κ ‖R_j − R_i R̃_ij‖²_F + τ ‖t_j − t_i − R_i t̃_ij‖² (no ½). Only a solver
//              that minimises f itself reaches SE-Sync's certified optimum f*.
//
// Initialisation:
//   odometry — iSAM's: edges in file order, the first pose at the origin, each new pose
//              composed from an initialised neighbour (forward or reverse).
//   chordal  — rotations by the chordal relaxation (unconstrained linear least squares on
//              the rotation matrices, projected onto SO(d); Martinec & Pajdla 2007,
//              Carlone et al. ICRA 2015), then translations by linear least squares with
//              the rotations fixed. First pose anchored at the origin.
//   landmarks — after the poses, in every initialisation: each landmark from its first
//              observation in file order, pose ⊕ measurement (iSAM's and g2o's rule); with
//              the file's initialisation a g2o VERTEX_XY / VERTEX_TRACKXYZ position first.
// Landmark observations are factors of their own kind (core/solver/landmark_factors.h); the
// SE-Sync objective has no landmark term, so it refuses a file with landmarks.

#include <vector>

#include "core/common/expected.h"
#include "core/solver/factor.h"
#include "core/solver/graph_io.h"
#include "core/solver/pose_graph.h"

namespace evermap::solver {

enum class Objective { kNative, kSeSync };
Expected<Objective> parseObjective(const std::string& text);  // "native", "sesync"

struct SeSyncWeights {
  double kappa = 0.0;
  double tau = 0.0;
};
SeSyncWeights seSyncWeights(const GraphEdge& edge, int dimension);

// Whether every edge can make a factor under `objective`: kNative needs a positive-definite
// information matrix (see resolveIndefiniteInformation), kSeSync positive-definite
// translation and rotation blocks (finite τ, κ > 0). The error names file:line and the edge.
Status checkInformation(const GraphFile& graph, Objective objective);

// SE-Sync's cost f of `values` over the file's edges (keys as in the file).
double seSyncCost(const GraphFile& graph, const Values& values);

// The factor of one edge under an objective. Contract: checkInformation holds for the edge.
FactorPtr makeEdgeFactor(const GraphFile& graph, const GraphEdge& edge, Objective objective);
// `kernel` for a factor of residual dimension `dim` (GNC-TLS without c̄²: χ²(dim, 0.99)).
RobustKernel kernelForFactor(const RobustKernel& kernel, int dim);
// iSAM's anchor: a prior at the origin with square-root information 100·I on `key`.
FactorPtr makeAnchorFactor(Key key, int dimension, double sqrt_information = 100.0);

// "Odometry" edges connect consecutive ids (|j − i| = 1); the rest are loop closures.
bool isOdometryEdge(const GraphEdge& edge);

// The id of the first pose (the first vertex, else the first edge's `from`).
Key firstPoseId(const GraphFile& graph);

Expected<Values> odometryInitialization(const GraphFile& graph);
// The odometry chain's poses only (no landmarks).
Expected<Values> odometryPoseInitialization(const GraphFile& graph);
// Appends every landmark not yet in `values` (see above); errors, naming file:line, when an
// observation's pose has no value or its landmark key holds a pose.
Status addLandmarkInitialization(const GraphFile& graph, bool file_positions, Values* values);
// The factor of one landmark observation (iSAM's and g2o's residual, which agree).
FactorPtr makeObservationFactor(const GraphFile& graph, const GraphObservation& observation);
Expected<Values> chordalInitialization(const GraphFile& graph);
// The file's own VERTEX lines; errors when an edge refers to a pose without one.
Expected<Values> fileInitialization(const GraphFile& graph);

struct BuildOptions {
  Objective objective = Objective::kNative;
  // Applied to loop-closure edges (and odometry edges too when robust_odometry).
  RobustKernel kernel;
  bool robust_odometry = false;
  // Anchor the first pose with iSAM's prior (square-root information 100·I).
  bool anchor = true;
};

// A PoseGraph with `initial` values and one factor per edge and per landmark observation
// (plus the anchor). The kernel goes on observations only with robust_odometry (all factors).
Expected<PoseGraph> buildPoseGraph(const GraphFile& graph, const Values& initial,
                                   const BuildOptions& options);

}  // namespace evermap::solver
