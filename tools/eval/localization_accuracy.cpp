#include "tools/eval/localization_accuracy.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <sstream>

#include <Eigen/Eigenvalues>

#include "core/common/percentile.h"

namespace evermap::eval {
namespace {

// True when the points' spread across their main direction is under 3 % of the spread along it
// (the second eigenvalue of their covariance under 1e-3 of the first).
bool alongOneLine(const std::vector<core::Vec3>& points) {
  core::Vec3 mean = core::Vec3::Zero();
  for (const core::Vec3& p : points) mean += p;
  mean /= static_cast<double>(points.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const core::Vec3& p : points) cov += (p - mean) * (p - mean).transpose();
  const Eigen::Vector3d l = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(cov).eigenvalues();
  return l[1] <= 1e-3 * l[2];
}

// The figures over the localized poses' errors.
void summarise(const std::vector<double>& errors, double rot2, LocalizationAccuracy* a) {
  a->poses_with_truth = static_cast<int64_t>(errors.size());
  if (errors.empty()) return;
  double sq = 0.0;
  for (double e : errors) sq += e * e;
  const auto n = static_cast<double>(errors.size());
  a->ate_rmse_m = std::sqrt(sq / n);
  a->ate_p95_m = percentile(errors, 0.95);
  a->ate_max_m = *std::max_element(errors.begin(), errors.end());
  a->rot_rmse_deg = std::sqrt(rot2 / n);
}

}  // namespace

Expected<core::Similarity> mapToTruth(const std::vector<core::SE3d>& map_nodes,
                                      const std::vector<core::SE3d>& true_nodes) {
  if (map_nodes.size() != true_nodes.size())
    return makeError("map to truth: ", map_nodes.size(), " nodes against ", true_nodes.size(),
                     " true poses");
  if (map_nodes.empty()) return makeError("map to truth: no node with truth");
  const core::Similarity by_first{1.0, true_nodes.front() * map_nodes.front().inverse()};
  if (map_nodes.size() < 3) return by_first;
  std::vector<core::Vec3> est, gt;
  for (size_t i = 0; i < map_nodes.size(); ++i) {
    est.push_back(map_nodes[i].translation());
    gt.push_back(true_nodes[i].translation());
  }
  // Nodes along one line (a map of one corridor) leave the rotation about it to the noise: the
  // fit may turn the map upside down about the line. The first node's whole pose decides then.
  if (alongOneLine(est)) return by_first;
  auto fit = core::umeyama(est, gt, false);
  if (!fit) return makeError("map to truth: ", fit.error().message);
  return fit->dst_S_src;
}

void countLocalized(const std::vector<LocalizedPose>& poses, LocalizationAccuracy* a) {
  a->poses = static_cast<int64_t>(poses.size());
  a->localized = 0;
  a->first_localized_s = -1;
  for (const LocalizedPose& p : poses) {
    if (!p.localized) continue;
    ++a->localized;
    if (a->first_localized_s < 0)
      a->first_localized_s = 1e-6 * static_cast<double>(p.utime - poses.front().utime);
  }
}

LocalizationAccuracy evaluateLocalization(std::vector<LocalizedPose>& poses,
                                          const core::Similarity& truth_S_map,
                                          const std::map<int64_t, core::SE3d>& truth,
                                          double false_m, double false_deg) {
  LocalizationAccuracy a;
  a.false_m = false_m;
  a.false_deg = false_deg;
  countLocalized(poses, &a);
  a.false_poses = a.false_placements = 0;
  std::vector<double> errors;
  double rot2 = 0.0;
  bool was_localized = false;
  for (LocalizedPose& p : poses) {
    const bool placement = p.localized && !was_localized;
    was_localized = p.localized;
    auto it = truth.lower_bound(p.utime - 25000);
    if (it == truth.end() || it->first > p.utime + 25000 || !p.placed) continue;
    const core::SE3d est = truth_S_map * p.world_T_body;
    p.error_m = (est.translation() - it->second.translation()).norm();
    const Eigen::AngleAxisd d(it->second.quaternion().conjugate() * est.quaternion());
    p.error_deg = std::abs(d.angle()) * 180.0 / std::numbers::pi;
    if (!p.localized) continue;
    errors.push_back(p.error_m);
    rot2 += p.error_deg * p.error_deg;
    const bool wrong = p.error_m > false_m || p.error_deg > false_deg;
    if (wrong) ++a.false_poses;
    if (wrong && placement) ++a.false_placements;
  }
  summarise(errors, rot2, &a);
  return a;
}

std::string truthLine(const LocalizationAccuracy& a) {
  std::ostringstream o;
  o << "truth frames_localized " << a.poses_with_truth << " ate_rmse_m " << a.ate_rmse_m
    << " ate_p95_m " << a.ate_p95_m << " ate_max_m " << a.ate_max_m << " rot_rmse_deg "
    << a.rot_rmse_deg << " false_frames " << a.false_poses << " false_placements "
    << a.false_placements << " (beyond " << a.false_m << " m or " << a.false_deg << " deg)\n";
  return o.str();
}

}  // namespace evermap::eval
