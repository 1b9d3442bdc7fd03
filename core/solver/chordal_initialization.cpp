// Chordal initialisation (declared in core/solver/graph_problem.h).
//
// Rotations: minimise Σ κ ‖R_j − R_i R̃_ij‖²_F over unconstrained d×d matrices with R_0 = I.
// Row r of the matrices decouples: x_j = R̃ᵀ x_i for x = (row r)ᵀ, so one sparse system
// with d right-hand sides. Each result is projected onto SO(d) (SVD). Translations then
// minimise Σ τ ‖t_j − t_i − R_i t̃_ij‖² with t_0 = 0. Both systems are solved with CHOLMOD.
#include <Eigen/SVD>

#include "core/solver/graph_problem.h"
#include "core/solver/ordering.h"
#include "core/solver/sparse_cholesky.h"

namespace evermap::solver {
namespace {

core::Mat3 projectToSO3(const core::Mat3& M) {
  Eigen::JacobiSVD<core::Mat3> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
  core::Mat3 D = core::Mat3::Identity();
  if ((svd.matrixU() * svd.matrixV().transpose()).determinant() < 0.0) D(2, 2) = -1.0;
  return svd.matrixU() * D * svd.matrixV().transpose();
}

}  // namespace

Expected<Values> chordalInitialization(const GraphFile& graph) {
  // Reachability and a key order come from the odometry chain.
  auto odo = odometryPoseInitialization(graph);
  if (!odo.ok()) return odo.error();
  const Values& chain = *odo;
  const int d = graph.dimension;
  const Key anchor = firstPoseId(graph);
  const int n = chain.size() - 1;  // unknowns: every pose but the anchor
  std::vector<int> unknown(chain.size(), -1);
  {
    int k = 0;
    for (int i = 0; i < chain.size(); ++i) {
      if (chain.keyAt(i) != anchor) unknown[i] = k++;
    }
  }
  Values out;
  if (n == 0) {
    out.add(anchor, chain[anchor]);
    if (auto st = addLandmarkInitialization(graph, false, &out); !st.ok()) return st.error();
    return out;
  }
  struct E {
    int i;  // unknown index or -1 for the anchor
    int j;
    Eigen::MatrixXd Rz;
    Eigen::VectorXd tz;
    SeSyncWeights w;
    int vi;  // index in chain
  };
  std::vector<E> edges;
  std::vector<std::pair<int, int>> pairs;
  std::vector<std::vector<int>> factor_vars;
  for (const GraphEdge& ge : graph.edges) {
    E e;
    e.vi = chain.indexOf(ge.from);
    e.i = unknown[e.vi];
    e.j = unknown[chain.indexOf(ge.to)];
    if (d == 2) {
      e.Rz = ge.measurement.se2.rotationMatrix();
      e.tz = ge.measurement.se2.translation();
    } else {
      e.Rz = ge.measurement.se3.rotationMatrix();
      e.tz = ge.measurement.se3.translation();
    }
    e.w = seSyncWeights(ge, d);
    if (e.i >= 0 && e.j >= 0) {
      pairs.emplace_back(e.i, e.j);
      factor_vars.push_back({e.i, e.j});
    } else if (e.i >= 0 || e.j >= 0) {
      factor_vars.push_back({std::max(e.i, e.j)});
    }
    edges.push_back(std::move(e));
  }
  const BlockPattern pattern(std::vector<int>(n, d), pairs);
  SparseCholesky chol;
  chol.analyze(pattern, fillReducingOrder(n, factor_vars));
  const Eigen::MatrixXd I = Eigen::MatrixXd::Identity(d, d);

  // Rotation system (the same matrix serves rotations and, scaled by τ, is rebuilt below).
  double* H = chol.values();
  Eigen::MatrixXd G = Eigen::MatrixXd::Zero(n * d, d);  // column r: right-hand side of row r
  for (const E& e : edges) {
    const double k = e.w.kappa;
    if (e.i >= 0) pattern.addBlock(e.i, e.i, k * I, H);
    if (e.j >= 0) pattern.addBlock(e.j, e.j, k * I, H);
    if (e.i >= 0 && e.j >= 0) {
      if (e.i < e.j)
        pattern.addBlock(e.i, e.j, -k * e.Rz, H);
      else
        pattern.addBlock(e.j, e.i, -k * e.Rz.transpose(), H);
    } else if (e.i < 0 && e.j >= 0) {
      G.middleRows(e.j * d, d) += k * e.Rz.transpose();  // columns e_r
    } else if (e.j < 0 && e.i >= 0) {
      G.middleRows(e.i * d, d) += k * e.Rz;
    }
  }
  if (auto st = chol.factorize(); !st.ok()) {
    return makeError(graph.path, ": chordal rotation system: ", st.error().message);
  }
  Eigen::MatrixXd X(n * d, d);
  for (int r = 0; r < d; ++r) X.col(r) = chol.solve(G.col(r));
  std::vector<Eigen::MatrixXd> R(chain.size());
  for (int v = 0; v < chain.size(); ++v) {
    if (unknown[v] < 0) {
      R[v] = I;
      continue;
    }
    // Row r of R_v is X.col(r) at the block of v.
    const Eigen::MatrixXd M = X.middleRows(unknown[v] * d, d).transpose();
    if (d == 2) {
      const double th = std::atan2(M(1, 0) - M(0, 1), M(0, 0) + M(1, 1));
      R[v] = core::SE2d(0, 0, th).rotationMatrix();
    } else {
      R[v] = projectToSO3(M);
    }
  }

  // Translation system.
  chol.zeroValues();
  Eigen::VectorXd g = Eigen::VectorXd::Zero(n * d);
  for (const E& e : edges) {
    const double t = e.w.tau;
    const Eigen::VectorXd rhs = R[e.vi] * e.tz;
    if (e.i >= 0) {
      pattern.addBlock(e.i, e.i, t * I, H);
      g.segment(e.i * d, d) -= t * rhs;
    }
    if (e.j >= 0) {
      pattern.addBlock(e.j, e.j, t * I, H);
      g.segment(e.j * d, d) += t * rhs;
    }
    if (e.i >= 0 && e.j >= 0) pattern.addBlock(std::min(e.i, e.j), std::max(e.i, e.j), -t * I, H);
  }
  if (auto st = chol.factorize(); !st.ok()) {
    return makeError(graph.path, ": chordal translation system: ", st.error().message);
  }
  const Eigen::VectorXd T = chol.solve(g);
  for (int v = 0; v < chain.size(); ++v) {
    const Key key = chain.keyAt(v);
    if (d == 2) {
      const double th = std::atan2(R[v](1, 0), R[v](0, 0));
      const Eigen::Vector2d t =
          unknown[v] < 0 ? Eigen::Vector2d::Zero() : Eigen::Vector2d(T.segment(unknown[v] * d, 2));
      out.add(key, PoseValue::planar(core::SE2d(t.x(), t.y(), th)));
    } else {
      const core::Vec3 t =
          unknown[v] < 0 ? core::Vec3::Zero() : core::Vec3(T.segment(unknown[v] * d, 3));
      out.add(key, PoseValue::spatial(core::SE3d(core::SO3d::fromMatrix(R[v]), t)));
    }
  }
  if (auto st = addLandmarkInitialization(graph, false, &out); !st.ok()) return st.error();
  return out;
}

}  // namespace evermap::solver
