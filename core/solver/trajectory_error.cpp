#include "core/solver/trajectory_error.h"

#include <cmath>

#include <Eigen/SVD>

namespace evermap::solver {
namespace {

Eigen::Vector3d position(const PoseValue& p) {
  if (p.kind == PoseKind::kSE2) return Eigen::Vector3d(p.se2.x(), p.se2.y(), 0.0);
  return p.se3.translation();
}

}  // namespace

Expected<TrajectoryError> absoluteTrajectoryError(const Values& estimate, const Values& truth) {
  std::vector<Eigen::Vector3d> e;
  std::vector<Eigen::Vector3d> g;
  for (int i = 0; i < estimate.size(); ++i) {
    const int j = truth.indexOf(estimate.keyAt(i));
    if (j < 0 || estimate.at(i).isPoint() || truth.at(j).isPoint()) continue;  // poses only
    e.push_back(position(estimate.at(i)));
    g.push_back(position(truth.at(j)));
  }
  if (e.size() < 3) return makeError("trajectory error: fewer than 3 poses in common");
  const double n = static_cast<double>(e.size());
  Eigen::Vector3d me = Eigen::Vector3d::Zero();
  Eigen::Vector3d mg = Eigen::Vector3d::Zero();
  for (size_t k = 0; k < e.size(); ++k) {
    me += e[k];
    mg += g[k];
  }
  me /= n;
  mg /= n;
  Eigen::Matrix3d C = Eigen::Matrix3d::Zero();
  for (size_t k = 0; k < e.size(); ++k) C += (g[k] - mg) * (e[k] - me).transpose();
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(C, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  if ((svd.matrixU() * svd.matrixV().transpose()).determinant() < 0.0) D(2, 2) = -1.0;
  const Eigen::Matrix3d R = svd.matrixU() * D * svd.matrixV().transpose();  // truth_R_estimate
  TrajectoryError out;
  out.matched = static_cast<int>(e.size());
  double sum = 0.0;
  for (size_t k = 0; k < e.size(); ++k) {
    const double d = (R * (e[k] - me) + mg - g[k]).norm();
    sum += d * d;
    out.max_m = std::max(out.max_m, d);
  }
  out.rmse_m = std::sqrt(sum / n);
  return out;
}

}  // namespace evermap::solver
