#include "tools/eval/localization_accuracy.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <sstream>
#include <tuple>
#include <utility>

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

// The localized poses' errors and how many of them are false (beyond the bounds), and how many
// placements (a first localized pose after one that was not).
struct Tally {
  Tally(double m, double deg) : false_m(m), false_deg(deg) {}
  double false_m, false_deg;  // a pose is false beyond either
  std::vector<double> errors;
  double rot2 = 0.0;
  int64_t false_poses = 0, false_placements = 0;

  void add(double error_m, double error_deg, bool placement) {
    errors.push_back(error_m);
    rot2 += error_deg * error_deg;
    const bool wrong = error_m > false_m || error_deg > false_deg;
    if (wrong) ++false_poses;
    if (wrong && placement) ++false_placements;
  }
  double rmseM() const {
    double sq = 0.0;
    for (double e : errors) sq += e * e;
    return std::sqrt(sq / static_cast<double>(errors.size()));
  }
  double rotRmseDeg() const { return std::sqrt(rot2 / static_cast<double>(errors.size())); }
};

// The position (m) and rotation (deg) error of `est` against `truth`.
std::pair<double, double> poseError(const core::SE3d& est, const core::SE3d& truth) {
  const Eigen::AngleAxisd d(truth.quaternion().conjugate() * est.quaternion());
  return {(est.translation() - truth.translation()).norm(),
          std::abs(d.angle()) * 180.0 / std::numbers::pi};
}

// The figures over the localized poses' errors.
void summarise(const Tally& t, LocalizationAccuracy* a) {
  a->poses_with_truth = static_cast<int64_t>(t.errors.size());
  a->false_poses = t.false_poses;
  a->false_placements = t.false_placements;
  if (t.errors.empty()) return;
  a->ate_rmse_m = t.rmseM();
  a->ate_p95_m = percentile(t.errors, 0.95);
  a->ate_max_m = *std::max_element(t.errors.begin(), t.errors.end());
  a->rot_rmse_deg = t.rotRmseDeg();
}

// The figures against the node tracked.
void summariseAgainstNode(const Tally& t, LocalizationAccuracy* a) {
  a->node_poses = static_cast<int64_t>(t.errors.size());
  if (t.errors.empty()) return;
  a->node_rmse_m = t.rmseM();
  a->node_rot_rmse_deg = t.rotRmseDeg();
  a->node_false_poses = t.false_poses;
  a->node_false_placements = t.false_placements;
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
                                          const std::map<int64_t, StoredNodeTruth>& nodes,
                                          double false_m, double false_deg) {
  LocalizationAccuracy a;
  a.false_m = false_m;
  a.false_deg = false_deg;
  countLocalized(poses, &a);
  Tally in_truth(false_m, false_deg), against_node(false_m, false_deg);
  bool was_localized = false;
  for (LocalizedPose& p : poses) {
    const bool placement = p.localized && !was_localized;
    was_localized = p.localized;
    auto it = truth.lower_bound(p.utime - 25000);
    if (it == truth.end() || it->first > p.utime + 25000 || !p.placed) continue;
    std::tie(p.error_m, p.error_deg) = poseError(truth_S_map * p.world_T_body, it->second);
    if (!p.localized) continue;
    in_truth.add(p.error_m, p.error_deg, placement);
    const auto node = nodes.find(p.node);
    if (node == nodes.end()) continue;
    const auto [m, deg] = poseError(node->second.world_T_node.inverse() * p.world_T_body,
                                    node->second.truth_T_node.inverse() * it->second);
    against_node.add(m, deg, placement);
  }
  summarise(in_truth, &a);
  summariseAgainstNode(against_node, &a);
  return a;
}

std::string truthLine(const LocalizationAccuracy& a) {
  std::ostringstream o;
  o << "truth frames_localized " << a.poses_with_truth << " ate_rmse_m " << a.ate_rmse_m
    << " ate_p95_m " << a.ate_p95_m << " ate_max_m " << a.ate_max_m << " rot_rmse_deg "
    << a.rot_rmse_deg << " false_frames " << a.false_poses << " false_placements "
    << a.false_placements << " (beyond " << a.false_m << " m or " << a.false_deg << " deg)\n";
  if (a.node_poses > 0)
    o << "truth_against_node frames " << a.node_poses << " ate_rmse_m " << a.node_rmse_m
      << " rot_rmse_deg " << a.node_rot_rmse_deg << " false_frames " << a.node_false_poses
      << " false_placements " << a.node_false_placements << "\n";
  return o.str();
}

}  // namespace evermap::eval
