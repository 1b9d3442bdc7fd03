#pragma once
// Pose-graph files: g2o (2-D and 3-D), TORO (2-D) and the iSAM text format; g2o writer.
//
//  g2o   VERTEX_SE2 id x y θ              EDGE_SE2 i j x y θ  I11 I12 I13 I22 I23 I33
//        VERTEX_SE3:QUAT id x y z qx qy qz qw
//        EDGE_SE3:QUAT i j x y z qx qy qz qw  I (21 upper-triangular entries, row by row)
//        FIX id                           (information, not square root; (t, q.xyz) order)
//  TORO  VERTEX2 id x y θ                 EDGE2 i j x y θ  Ixx Ixy Iyy Iθθ Ixθ Iyθ
//  iSAM  ODOMETRY|EDGE2 i j x y θ  sxx sxy sxθ syy syθ sθθ   (square-root information)
//        EDGE3 i j x y z roll pitch yaw  s11 ... s66 (21 upper-triangular entries)
//        iSAM 1.6's Loader reads the angles of EDGE3 as roll, pitch, yaw (the first angle
//        is roll), stores them as (yaw, pitch, roll) and reverses the lower-right 3x3 of the
//        square root accordingly; we do exactly the same, so the costs are iSAM's.
// Point landmarks (2-D and 3-D): a pose observes a point in its own frame.
//  iSAM  LANDMARK i j x y  sxx sxy syy        (pose i, landmark j; square-root information)
//        POINT3 i j x y z [s11 s12 s13 s22 s23 s33]   (no numbers: identity, as iSAM)
//        iSAM numbers landmarks apart from poses: landmark j gets the key
//        kIsamLandmarkKeyBase + j (isamLandmarkKey). iSAM 1.6/1.7's Loader has no other
//        landmark lines (no POINT2D / POINT3D), nor have we.
//  g2o   VERTEX_XY id x y                     EDGE_SE2_XY i j x y  I11 I12 I22
//        VERTEX_TRACKXYZ id x y z             EDGE_SE3_TRACKXYZ i j param x y z  I (6 entries)
//        PARAMS_SE3OFFSET param x y z qx qy qz qw  (the sensor's pose in the robot's frame)
//        (information, upper triangle row by row; one id space for poses and landmarks)
// A landmark line whose pose or point is of the wrong dimension, whose parameter is unknown
// or whose numbers are malformed is an error naming file:line.
// Every edge measures pose j in the frame of pose i (i_T_j). Lines that are blank or start
// with '#' are ignored; lines with another tag are skipped and counted. A malformed line, a
// value that is not finite or an information matrix that is not symmetric is an error naming
// file:line.
//
// Indefinite information matrices (SE-Sync's cubicle.g2o has 5,021 of 16,869: full 6x6
// matrices that are not positive definite although their translation and rotation blocks
// are) are read and kept as they are (GraphEdge::indefinite_information, no square root).
// What happens to them is the caller's rule, applied to the whole file before factors are
// made (resolveIndefiniteInformation; docs/solver.md):
//   refuse  — an error naming file:line, the edge and the smallest eigenvalue (default);
//   blocks  — keep the translation and rotation blocks, drop their coupling (what SE-Sync's
//             cost uses anyway); refused when a block itself is not positive definite;
//   nearest — the nearest positive-definite matrix: eigenvalues raised to ε·λ_max
//             (ε = 1e-6), eigenvectors kept (Higham 1988, "Computing a nearest symmetric
//             positive semidefinite matrix", with a floor so the result is invertible).
// SE-Sync's objective needs only the blocks, so it uses them directly whatever the rule.

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/common/expected.h"
#include "core/solver/values.h"

namespace evermap::solver {

enum class GraphFormat { kAuto, kG2o, kToro, kIsam };
const char* graphFormatName(GraphFormat f);

struct GraphVertex {
  Key id = 0;
  PoseValue pose;
};

struct GraphEdge {
  Key from = 0;
  Key to = 0;
  PoseValue measurement;  // from_T_to
  // Upper triangular, in the format's residual order; empty when the file's information
  // matrix is not positive definite (then indefinite_information holds it).
  Eigen::MatrixXd sqrt_information;
  Eigen::MatrixXd indefinite_information;  // symmetric, as read; empty unless indefinite
  int line = 0;                            // 1-based line in the file
  bool positiveDefinite() const { return sqrt_information.size() > 0; }
  Eigen::MatrixXd information() const {
    return positiveDefinite() ? Eigen::MatrixXd(sqrt_information.transpose() * sqrt_information)
                              : indefinite_information;
  }
};

// iSAM's landmark ids live apart from its pose ids; the solver has one key space.
inline constexpr Key kIsamLandmarkKeyBase = 1'000'000'000;
inline Key isamLandmarkKey(Key landmark_id) { return kIsamLandmarkKeyBase + landmark_id; }

// A landmark with a position in the file (g2o VERTEX_XY / VERTEX_TRACKXYZ).
struct GraphLandmark {
  Key id = 0;
  PoseValue position;  // kPoint2 or kPoint3, world frame
};

// A pose observing a landmark: the point in the pose's frame (2-D: z of `measured` is 0).
struct GraphObservation {
  Key pose = 0;
  Key landmark = 0;
  core::Vec3 measured = core::Vec3::Zero();
  Eigen::MatrixXd sqrt_information;  // upper triangular, 2x2 or 3x3
  core::SE3d pose_T_sensor;          // g2o's PARAMS_SE3OFFSET (3-D), else identity
  int offset_param = -1;             // g2o parameter id, -1 when none
  int line = 0;
  // Edges (pose-pose) that came before this line in the file: the online order.
  int edges_before = 0;
};

struct GraphFile {
  std::string path;
  GraphFormat format = GraphFormat::kG2o;
  int dimension = 2;                           // 2 or 3
  std::vector<GraphVertex> vertices;           // file order
  std::vector<GraphEdge> edges;                // file order
  std::vector<GraphLandmark> landmarks;        // file order (g2o only)
  std::vector<GraphObservation> observations;  // file order
  std::map<int, core::SE3d> sensor_offsets;    // g2o PARAMS_SE3OFFSET
  std::vector<Key> fixed;                      // g2o FIX
  std::map<std::string, int> skipped_tags;
  int skippedLines() const;
  // Distinct landmarks observed or defined.
  int numLandmarks() const;
};

// Reads a file; kAuto decides by content (g2o tags; VERTEX2 or a .graph name → TORO;
// ODOMETRY or EDGE2/EDGE3 without vertices → iSAM).
Expected<GraphFile> readGraphFile(const std::filesystem::path& path,
                                  GraphFormat format = GraphFormat::kAuto);

enum class IndefiniteInformation { kRefuse, kBlocks, kNearest };
Expected<IndefiniteInformation> parseIndefiniteInformation(const std::string& text);

// The nearest symmetric matrix to `information` (symmetric) whose eigenvalues are at least
// relative_floor · λ_max (λ_max > 0 required).
Eigen::MatrixXd nearestPositiveDefinite(const Eigen::MatrixXd& information,
                                        double relative_floor = 1e-6);

// Applies `rule` to every edge without a square root (see above); returns how many edges it
// changed. kRefuse errors on the first such edge, naming it.
Expected<int> resolveIndefiniteInformation(GraphFile* graph, IndefiniteInformation rule);

// Writes vertices (poses and landmarks from `values`, keyed as in the solver) and edges and
// observations in g2o format, to a temporary name in the same folder, then renamed. Edge
// information is WᵀW of each edge (landmark residuals are the same in iSAM and g2o).
Status writeG2o(const std::filesystem::path& path, const GraphFile& graph, const Values& values);

}  // namespace evermap::solver
