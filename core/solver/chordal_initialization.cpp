// Chordal initialisation (declared in core/solver/graph_problem.h).
//
// Rotations: minimise Σ κ ‖R_j − R_i R̃_ij‖²_F over unconstrained d×d matrices with R_0 = I.
// Row r of the matrices decouples: x_j = R̃ᵀ x_i for x = (row r)ᵀ, so one sparse system
// with d right-hand sides. Each result is projected onto SO(d) (SVD). Translations then
// minimise Σ τ ‖t_j − t_i − R_i t̃_ij‖² with t_0 = 0. Both systems are solved with CHOLMOD.
#include <optional>

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

// One edge as the two linear systems see it.
struct ChordalEdge {
  int i;  // unknown index or -1 for the anchor
  int j;
  Eigen::MatrixXd Rz;
  Eigen::VectorXd tz;
  SeSyncWeights w;
  int vi;  // index in chain
};

// The unknowns (every pose of the odometry chain but the anchor), the edges between them and
// the sparse matrix the rotation and the translation systems share.
class ChordalSystem {
 public:
  ChordalSystem(const GraphFile& graph, const Values& chain, Key anchor);

  // The rotation of every pose of the chain (the anchor's is I), projected onto SO(d).
  Expected<std::vector<Eigen::MatrixXd>> rotations(const std::string& path);
  // The translations of the unknowns given their rotations.
  Expected<Eigen::VectorXd> translations(const std::vector<Eigen::MatrixXd>& R,
                                         const std::string& path);
  int unknown(int v) const { return unknown_[v]; }

 private:
  int d_;
  int n_;
  std::vector<int> unknown_;  // per chain index: unknown index, or -1 for the anchor
  std::vector<ChordalEdge> edges_;
  std::optional<BlockPattern> pattern_;
  SparseCholesky chol_;
};

ChordalSystem::ChordalSystem(const GraphFile& graph, const Values& chain, Key anchor)
    : d_(graph.dimension), n_(chain.size() - 1), unknown_(chain.size(), -1) {
  int k = 0;
  for (int i = 0; i < chain.size(); ++i) {
    if (chain.keyAt(i) != anchor) unknown_[i] = k++;
  }
  std::vector<std::pair<int, int>> pairs;
  std::vector<std::vector<int>> factor_vars;
  for (const GraphEdge& ge : graph.edges) {
    ChordalEdge e;
    e.vi = chain.indexOf(ge.from);
    e.i = unknown_[e.vi];
    e.j = unknown_[chain.indexOf(ge.to)];
    if (d_ == 2) {
      e.Rz = ge.measurement.se2.rotationMatrix();
      e.tz = ge.measurement.se2.translation();
    } else {
      e.Rz = ge.measurement.se3.rotationMatrix();
      e.tz = ge.measurement.se3.translation();
    }
    e.w = seSyncWeights(ge, d_);
    if (e.i >= 0 && e.j >= 0) {
      pairs.emplace_back(e.i, e.j);
      factor_vars.push_back({e.i, e.j});
    } else if (e.i >= 0 || e.j >= 0) {
      factor_vars.push_back({std::max(e.i, e.j)});
    }
    edges_.push_back(std::move(e));
  }
  pattern_.emplace(std::vector<int>(n_, d_), pairs);
  chol_.analyze(*pattern_, fillReducingOrder(n_, factor_vars));
}

Expected<std::vector<Eigen::MatrixXd>> ChordalSystem::rotations(const std::string& path) {
  const int d = d_;
  const Eigen::MatrixXd I = Eigen::MatrixXd::Identity(d, d);
  double* H = chol_.values();
  Eigen::MatrixXd G = Eigen::MatrixXd::Zero(n_ * d, d);  // column r: right-hand side of row r
  for (const ChordalEdge& e : edges_) {
    const double k = e.w.kappa;
    if (e.i >= 0) pattern_->addBlock(e.i, e.i, k * I, H);
    if (e.j >= 0) pattern_->addBlock(e.j, e.j, k * I, H);
    if (e.i >= 0 && e.j >= 0) {
      if (e.i < e.j)
        pattern_->addBlock(e.i, e.j, -k * e.Rz, H);
      else
        pattern_->addBlock(e.j, e.i, -k * e.Rz.transpose(), H);
    } else if (e.i < 0 && e.j >= 0) {
      G.middleRows(e.j * d, d) += k * e.Rz.transpose();  // columns e_r
    } else if (e.j < 0 && e.i >= 0) {
      G.middleRows(e.i * d, d) += k * e.Rz;
    }
  }
  if (auto st = chol_.factorize(); !st.ok()) {
    return makeError(path, ": chordal rotation system: ", st.error().message);
  }
  Eigen::MatrixXd X(n_ * d, d);
  for (int r = 0; r < d; ++r) X.col(r) = chol_.solve(G.col(r));
  std::vector<Eigen::MatrixXd> R(unknown_.size());
  for (size_t v = 0; v < unknown_.size(); ++v) {
    if (unknown_[v] < 0) {
      R[v] = I;
      continue;
    }
    // Row r of R_v is X.col(r) at the block of v.
    const Eigen::MatrixXd M = X.middleRows(unknown_[v] * d, d).transpose();
    if (d == 2) {
      const double th = std::atan2(M(1, 0) - M(0, 1), M(0, 0) + M(1, 1));
      R[v] = core::SE2d(0, 0, th).rotationMatrix();
    } else {
      R[v] = projectToSO3(M);
    }
  }
  return R;
}

Expected<Eigen::VectorXd> ChordalSystem::translations(const std::vector<Eigen::MatrixXd>& R,
                                                      const std::string& path) {
  const int d = d_;
  const Eigen::MatrixXd I = Eigen::MatrixXd::Identity(d, d);
  double* H = chol_.values();
  chol_.zeroValues();
  Eigen::VectorXd g = Eigen::VectorXd::Zero(n_ * d);
  for (const ChordalEdge& e : edges_) {
    const double t = e.w.tau;
    const Eigen::VectorXd rhs = R[e.vi] * e.tz;
    if (e.i >= 0) {
      pattern_->addBlock(e.i, e.i, t * I, H);
      g.segment(e.i * d, d) -= t * rhs;
    }
    if (e.j >= 0) {
      pattern_->addBlock(e.j, e.j, t * I, H);
      g.segment(e.j * d, d) += t * rhs;
    }
    if (e.i >= 0 && e.j >= 0) pattern_->addBlock(std::min(e.i, e.j), std::max(e.i, e.j), -t * I, H);
  }
  if (auto st = chol_.factorize(); !st.ok()) {
    return makeError(path, ": chordal translation system: ", st.error().message);
  }
  return chol_.solve(g);
}

}  // namespace

Expected<Values> chordalInitialization(const GraphFile& graph) {
  // Reachability and a key order come from the odometry chain.
  auto odo = odometryPoseInitialization(graph);
  if (!odo.ok()) return odo.error();
  const Values& chain = *odo;
  const int d = graph.dimension;
  const Key anchor = firstPoseId(graph);
  Values out;
  if (chain.size() == 1) {  // no unknown: the anchor alone
    out.add(anchor, chain[anchor]);
    if (auto st = addLandmarkInitialization(graph, false, &out); !st.ok()) return st.error();
    return out;
  }
  ChordalSystem system(graph, chain, anchor);
  const Expected<std::vector<Eigen::MatrixXd>> R = system.rotations(graph.path);
  if (!R) return R.error();
  const Expected<Eigen::VectorXd> T = system.translations(*R, graph.path);
  if (!T) return T.error();
  for (int v = 0; v < chain.size(); ++v) {
    const Key key = chain.keyAt(v);
    const int u = system.unknown(v);
    if (d == 2) {
      const double th = std::atan2((*R)[v](1, 0), (*R)[v](0, 0));
      const Eigen::Vector2d t =
          u < 0 ? Eigen::Vector2d::Zero() : Eigen::Vector2d(T->segment(u * d, 2));
      out.add(key, PoseValue::planar(core::SE2d(t.x(), t.y(), th)));
    } else {
      const core::Vec3 t = u < 0 ? core::Vec3::Zero() : core::Vec3(T->segment(u * d, 3));
      out.add(key, PoseValue::spatial(core::SE3d(core::SO3d::fromMatrix((*R)[v]), t)));
    }
  }
  if (auto st = addLandmarkInitialization(graph, false, &out); !st.ok()) return st.error();
  return out;
}

}  // namespace evermap::solver
