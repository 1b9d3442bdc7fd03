#include "tools/slam-run/truth_evaluation.h"

#include <cmath>
#include <numbers>

#include "core/common/percentile.h"
#include "core/geometry/se2.h"
#include "mapper-proc/constraint_set.h"
#include "tools/mapper-run/run_metrics.h"

namespace evermap::slam_run {
namespace {

// e' Σ⁻¹ e of an estimate's error err = truth⁻¹ · estimate, as the mapper's gates compute it
// (ConstraintSet::mahalanobis2 against the exact truth); -1 without a covariance.
double normalisedError(const core::SE3d& err, const core::Mat6& covariance) {
  if (!covariance.allFinite() || covariance.isZero()) return -1.0;
  const double d2 = mapper::ConstraintSet::mahalanobis2(core::UncertainPose{}, {err, covariance});
  return std::isfinite(d2) ? d2 : -1.0;
}

}  // namespace

std::vector<HourFigures> hourFigures(const std::vector<SlamRunner::FrameRow>& frames) {
  std::vector<HourFigures> hours;
  for (size_t i = 0; i < frames.size();) {
    HourFigures h;
    h.hour = static_cast<int>(frames[i].run_s / 3600.0);
    std::vector<double> mapper_ms, loopclose_ms;
    for (; i < frames.size() && static_cast<int>(frames[i].run_s / 3600.0) == h.hour; ++i) {
      mapper_ms.push_back(frames[i].mapper_ms);
      loopclose_ms.push_back(frames[i].loopclose_ms);
      h.nodes_at_end = frames[i].nodes;
    }
    h.frames = static_cast<int64_t>(mapper_ms.size());
    h.mapper_p99_ms = percentile(std::move(mapper_ms), 0.99);
    h.loopclose_p99_ms = percentile(std::move(loopclose_ms), 0.99);
    hours.push_back(h);
  }
  return hours;
}

std::map<int64_t, core::SE3d> nodeTruth(const mapper::Mapper& m, const mapper::RunTruth& truth) {
  std::map<int64_t, core::SE3d> node_truth;
  for (const mapper::MapperNode& n : m.nodes()) {
    core::SE3d p;
    if (truth.at(n.keyframe_utime, &p)) node_truth[n.id] = p;
  }
  return node_truth;
}

std::vector<SlamRunSummary::NodeRow> nodeRows(
    const mapper::Mapper& m, const std::map<int64_t, core::SE3d>& node_truth,
    const std::map<int64_t, std::pair<int, int>>& truth_floor) {
  std::vector<SlamRunSummary::NodeRow> rows;
  for (const auto& [id, p] : node_truth) {
    const mapper::MapperNode& n = m.nodes()[static_cast<size_t>(id)];
    const core::SE3d est = m.nodePose(id);
    SlamRunSummary::NodeRow row{id,
                                n.session,
                                n.floor,
                                -1,
                                n.keyframe_utime,
                                p.translation(),
                                est.translation(),
                                core::toPlanar(p).theta(),
                                core::toPlanar(est).theta(),
                                p.quaternion(),
                                est.quaternion()};
    auto f = truth_floor.lower_bound(n.keyframe_utime);
    if (f != truth_floor.end()) row.true_floor = f->second.first;
    rows.push_back(row);
  }
  return rows;
}

int64_t falseClosures(const mapper::Mapper& m, const std::map<int64_t, core::SE3d>& node_truth,
                      double max_m, double max_deg, int64_t* with_truth) {
  int64_t false_closures = 0;
  for (const auto& c : m.constraints().all()) {
    if (!c.accepted || c.kind != mapper::ConstraintKind::kLoop) continue;
    auto a = node_truth.find(c.from), b = node_truth.find(c.to);
    if (a == node_truth.end() || b == node_truth.end()) continue;
    ++*with_truth;
    const core::SE3d err = (a->second.inverse() * b->second).inverse() * c.from_T_to.mean;
    if (err.translation().norm() > max_m ||
        core::rotationAngle(err.so3()) * 180.0 / std::numbers::pi > max_deg)
      ++false_closures;
  }
  return false_closures;
}

void scoreRegistration(const mapper::RunTruth& truth, SlamRunner::RegistrationRow* row) {
  core::SE3d b, q;
  if (row->node < 0 || !truth.at(row->node_keyframe_utime, &b) || !truth.at(row->query_utime, &q))
    return;
  const core::SE3d err = (b.inverse() * q).inverse() * row->b_T_q;
  row->error_m = err.translation().norm();
  row->error_deg = core::rotationAngle(err.so3()) * 180.0 / std::numbers::pi;
  row->nees = normalisedError(err, row->b_T_q_covariance);
  core::SE3d a;
  if (row->active < 0 || !truth.at(row->active_keyframe_utime, &a)) return;
  const core::SE3d delta_err = (a.inverse() * q).inverse() * row->active_T_q.mean;
  row->delta_error_m = delta_err.translation().norm();
  row->delta_error_deg = core::rotationAngle(delta_err.so3()) * 180.0 / std::numbers::pi;
  row->delta_nees = normalisedError(delta_err, row->active_T_q.covariance);
}

std::vector<sim::ReachSample> registrationReach(
    const std::vector<SlamRunner::RegistrationRow>& rows, const mapper::RunTruth& truth,
    const core::SE3d& body_T_cam, double max_m, double max_deg) {
  std::vector<sim::ReachSample> reach;
  for (const SlamRunner::RegistrationRow& row : rows) {
    core::SE3d n, q;
    if (row.requested_node < 0 || !truth.at(row.requested_keyframe_utime, &n) ||
        !truth.at(row.query_utime, &q))
      continue;
    if (std::abs(n.translation().z() - q.translation().z()) > 1.0) continue;
    const bool ok = row.status == register_result_t::STATUS_OK && row.node == row.requested_node &&
                    row.error_m >= 0.0 && row.error_m <= max_m && row.error_deg <= max_deg;
    reach.push_back({(n.translation() - q.translation()).norm(),
                     sim::viewAngle(n * body_T_cam, q * body_T_cam), ok});
  }
  return reach;
}

void countNodesInMappedArea(const mapper::Mapper& m,
                            const std::map<int64_t, core::SE3d>& node_truth,
                            std::vector<SessionSummary>* sessions) {
  for (SessionSummary& ss : *sessions) ss.nodes_in_mapped_area = 0;
  for (const mapper::MapperNode& n : m.nodes()) {
    auto it = node_truth.find(n.id);
    if (it == node_truth.end()) continue;
    const core::SE2d p = core::toPlanar(it->second);
    for (const mapper::MapperNode& o : m.nodes()) {
      if (o.session >= n.session) continue;
      auto jt = node_truth.find(o.id);
      if (jt == node_truth.end()) continue;
      const core::SE2d q = core::toPlanar(jt->second);
      const double dyaw = std::remainder(p.theta() - q.theta(), 2.0 * std::numbers::pi);
      if ((p.translation() - q.translation()).norm() <= 1.0 &&
          std::abs(dyaw) <= std::numbers::pi / 8 &&
          std::abs(it->second.translation().z() - jt->second.translation().z()) < 1.0) {
        for (SessionSummary& ss : *sessions)
          if (ss.session == n.session) ++ss.nodes_in_mapped_area;
        break;
      }
    }
  }
}

}  // namespace evermap::slam_run
