#include "tools/mapper-run/offline_run.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <map>
#include <numbers>
#include <optional>
#include <sstream>
#include <utility>

#include "core/geometry/se2.h"
#include "tools/eval/alignment.h"
#include "tools/eval/metrics.h"
#include "tools/mapper-run/offline_mapping.h"
#include "tools/mapper-run/run_metrics.h"

namespace evermap::mapper {
namespace {

// Ground truth at `utime`: linear in position between the samples around it, rotation of
// the nearer one (samples are 0.1 s apart; the rotation error of that is below the metric's
// interest here).
core::SE3d truthAt(const std::map<int64_t, core::SE3d>& gt, int64_t utime) {
  auto hi = gt.lower_bound(utime);
  if (hi == gt.end()) return std::prev(hi)->second;
  if (hi->first == utime || hi == gt.begin()) return hi->second;
  auto lo = std::prev(hi);
  const double a =
      static_cast<double>(utime - lo->first) / static_cast<double>(hi->first - lo->first);
  const core::Vec3 t = (1 - a) * lo->second.translation() + a * hi->second.translation();
  return core::SE3d(a < 0.5 ? lo->second.so3() : hi->second.so3(), t);
}

// The true floor at step pose `utime` (that of its keyframe), if known.
std::optional<int> floorAt(const std::vector<std::pair<int64_t, int>>& step_floor, int64_t utime) {
  auto it = std::lower_bound(step_floor.begin(), step_floor.end(), std::make_pair(utime, INT_MIN));
  if (it != step_floor.end() && it->first == utime) return it->second;
  return std::nullopt;
}

// Nodes by session, and the cause of each new node (run_metrics.h, PlaceCause).
void countNodes(const Mapper& mapper, const std::vector<NodeTruth>& node_truth,
                const OfflineRunOptions& run, OfflineRunSummary* out) {
  for (const MapperNode& n : mapper.nodes()) {
    if (n.session >= static_cast<int>(out->nodes_by_session.size()))
      out->nodes_by_session.resize(n.session + 1, 0);
    ++out->nodes_by_session[n.session];
  }
  const std::vector<PlaceCause> causes =
      placeCauses(node_truth, node_truth, run.revisit_radius_m, run.revisit_angle_rad);
  // The same test at twice the radius and angle (2 m, 45°: the partition's sector).
  const std::vector<PlaceCause> near =
      placeCauses(node_truth, node_truth, 2.0 * run.revisit_radius_m, 2.0 * run.revisit_angle_rad);
  for (auto* v : {&out->nodes_in_mapped_area_by_session, &out->nodes_new_heading_by_session,
                  &out->nodes_new_place_by_session, &out->nodes_near_a_view_by_session})
    v->assign(out->nodes_by_session.size(), 0);
  for (size_t k = 0; k < causes.size(); ++k) {
    const auto s = static_cast<size_t>(mapper.nodes()[k].session);
    if (s >= out->nodes_by_session.size()) continue;
    if (causes[k] == PlaceCause::kMapped) ++out->nodes_in_mapped_area_by_session[s];
    if (causes[k] == PlaceCause::kNewHeading) ++out->nodes_new_heading_by_session[s];
    if (causes[k] == PlaceCause::kNewPlace) ++out->nodes_new_place_by_session[s];
    if (causes[k] != PlaceCause::kMapped && near[k] == PlaceCause::kMapped)
      ++out->nodes_near_a_view_by_session[s];
  }
}

// Where the robot was at each step, against the same nodes: how much of each session went
// through areas mapped before it.
void countSteps(const Mapper& mapper, const RunTruthRecord& truth,
                const std::vector<NodeTruth>& node_truth, const OfflineRunOptions& run,
                OfflineRunSummary* out) {
  std::vector<NodeTruth> steps;
  for (const auto& p : mapper.stepPoses()) {
    if (truth.world_T_body.empty()) break;
    const std::optional<int> floor = floorAt(truth.step_floor, p.utime);
    steps.push_back(NodeTruth{truthAt(truth.world_T_body, p.utime), floor.value_or(-1), p.session,
                              floor.has_value()});
    if (p.session >= static_cast<int>(out->steps_by_session.size()))
      out->steps_by_session.resize(p.session + 1, 0);
    ++out->steps_by_session[p.session];
  }
  out->steps_in_mapped_area_by_session =
      inMappedArea(node_truth, steps, run.revisit_radius_m, run.revisit_angle_rad);
  out->steps_in_mapped_area_by_session.resize(out->steps_by_session.size(), 0);
}

// One pass over the node pairs: those between floors against the truth, and the session each
// was opened in (that of the step at or after its first constraint).
void countPairs(const Mapper& mapper, const std::vector<NodeTruth>& node_truth,
                OfflineRunSummary* out) {
  const auto& poses = mapper.stepPoses();
  const size_t sessions = out->nodes_by_session.size();
  for (auto* v : {&out->pairs_by_session, &out->pairs_between_earlier_nodes_by_session})
    v->assign(sessions, 0);
  double yaw2 = 0.0, claimed2 = 0.0;
  for (const auto& [key, pair] : mapper.constraints().pairs()) {
    if (static_cast<size_t>(key.second) < node_truth.size()) {
      const NodeTruth& a = node_truth[key.first];
      const NodeTruth& b = node_truth[key.second];
      if (a.known && b.known && a.floor != b.floor) {
        const core::SE3d err =
            (a.world_T_body.inverse() * b.world_T_body).inverse() * pair.i_T_j.mean;
        const double yaw = err.so3().rollPitchYaw().z();
        yaw2 += yaw * yaw;
        claimed2 += pair.i_T_j.covariance(5, 5);
        ++out->interfloor_pairs;
      }
    }
    const int64_t utime = mapper.constraints().all()[pair.members.front()].utime;
    auto it = std::lower_bound(poses.begin(), poses.end(), utime,
                               [](const Mapper::StepPose& p, int64_t t) { return p.utime < t; });
    if (it == poses.end()) --it;
    const auto s = static_cast<size_t>(it->session);
    if (s >= sessions) continue;
    ++out->pairs_by_session[s];
    const int last =
        std::max(mapper.nodes()[key.first].session, mapper.nodes()[key.second].session);
    if (last < it->session) ++out->pairs_between_earlier_nodes_by_session[s];
  }
  if (out->interfloor_pairs > 0) {
    const double n = static_cast<double>(out->interfloor_pairs);
    out->interfloor_yaw_rms_deg = std::sqrt(yaw2 / n) * 180.0 / std::numbers::pi;
    out->interfloor_yaw_claimed_deg = std::sqrt(claimed2 / n) * 180.0 / std::numbers::pi;
  }
}

// Solver updates and mapper steps: over the run, and the step's in its first and last hour
// of operating time.
void stepTimes(const Mapper& mapper, const RunTruthRecord& truth, double operating_s,
               OfflineRunSummary* out) {
  std::vector<double> ms;
  for (double s : mapper.stats().timing.update_s) ms.push_back(1e3 * s);
  out->update_median_ms = percentile(ms, 0.5);
  out->update_p99_ms = percentile(ms, 0.99);
  std::vector<double> all, first_hour, last_hour, first_hour_cpu, last_hour_cpu;
  const auto& offsets = truth.session_offsets;
  for (const auto& c : mapper.stats().timing.step_cost) {
    auto it = std::upper_bound(offsets.begin(), offsets.end(), std::make_pair(c.utime, 1e300));
    if (it == offsets.begin()) continue;
    --it;
    const double t = it->second + 1e-6 * static_cast<double>(c.utime - it->first);
    all.push_back(1e3 * c.s);
    if (t < 3600.0) first_hour.push_back(1e3 * c.s);
    if (t >= operating_s - 3600.0) last_hour.push_back(1e3 * c.s);
    if (t < 3600.0) first_hour_cpu.push_back(1e3 * c.cpu_s);
    if (t >= operating_s - 3600.0) last_hour_cpu.push_back(1e3 * c.cpu_s);
  }
  out->step_median_ms = percentile(all, 0.5);
  out->step_p99_ms = percentile(all, 0.99);
  out->step_p99_first_hour_ms = percentile(first_hour, 0.99);
  out->step_p99_last_hour_ms = percentile(last_hour, 0.99);
  out->step_cpu_p99_first_hour_ms = percentile(first_hour_cpu, 0.99);
  out->step_cpu_p99_last_hour_ms = percentile(last_hour_cpu, 0.99);
}

// The step poses' ATE after an SE(3) alignment, and each step's and node's error under it.
Status trajectoryErrors(const Mapper& mapper, const RunTruthRecord& truth,
                        const std::vector<NodeTruth>& node_truth, OfflineRunSummary* out) {
  std::vector<core::SE3d> gt, est;
  for (const auto& p : mapper.stepPoses()) {
    if (truth.world_T_body.empty()) break;
    gt.push_back(truthAt(truth.world_T_body, p.utime));
    est.push_back(mapper.nodePose(p.node) * p.node_T_body);
  }
  out->step_poses = static_cast<int64_t>(est.size());
  if (est.size() < 3) return Ok{};  // too little mapped (a run resumed at its very end)
  auto aligned = eval::alignTrajectories(gt, est, eval::AlignmentMode::kSE3);
  if (!aligned) return makeError("offline run: ATE: ", aligned.error().message);
  for (auto& e : est) e = aligned->gt_S_est * e;
  auto ate = eval::computeAte(gt, est);
  if (!ate) return makeError("offline run: ATE: ", ate.error().message);
  out->ate_rmse_m = ate->translation_m.rmse;
  out->ate_median_m = ate->translation_m.median;
  for (size_t k = 0; k < gt.size(); ++k) {
    out->trajectory_gt.push_back(gt[k].translation());
    out->trajectory_est.push_back(est[k].translation());
    const Mapper::StepPose& p = mapper.stepPoses()[k];
    out->step_errors.push_back({p.utime, p.session, p.node,
                                floorAt(truth.step_floor, p.utime).value_or(-1),
                                (gt[k].translation() - est[k].translation()).norm(),
                                core::toPlanar(gt[k].inverse() * est[k]).theta() * 180.0 / M_PI});
  }
  for (const MapperNode& n : mapper.nodes()) {
    if (n.id >= static_cast<int64_t>(node_truth.size()) || !node_truth[n.id].known) continue;
    out->nodes_gt.push_back(node_truth[n.id].world_T_body.translation());
    out->nodes_est.push_back((aligned->gt_S_est * mapper.nodePose(n.id)).translation());
    out->node_errors.push_back({n.id, n.session, n.floor, n.keyframe_utime,
                                (out->nodes_gt.back() - out->nodes_est.back()).norm(),
                                node_truth[n.id].world_T_body});
  }
  return Ok{};
}

}  // namespace

Status OfflineRunOptions::validate() const {
  if (first_session < 0) return Error{"run.first_session: must be >= 0"};
  if (last_session >= 0 && last_session < first_session)
    return Error{"run.last_session: must be >= first_session"};
  if (!(timeline_interval_s >= 0.0)) return Error{"run.timeline_interval_s: must be >= 0"};
  if (!(revisit_radius_m > 0.0) || !(revisit_angle_rad > 0.0))
    return Error{"run.revisit_*: must be > 0"};
  if (!(max_wall_s >= 0.0)) return Error{"run.max_wall_s: must be >= 0"};
  if (!(stop_after_s >= 0.0)) return Error{"run.stop_after_s: must be >= 0"};
  if (!(store_period_s >= 0.0)) return Error{"run.store_period_s: must be >= 0"};
  if (!(restart_gap_s >= 0.0) || !std::isfinite(restart_gap_s))
    return Error{"run.restart_gap_s: must be >= 0"};
  if (!(progress_period_s >= 0.0)) return Error{"run.progress_period_s: must be >= 0"};
  return Ok{};
}

namespace {

// One line "NAME v0 v1 ...".
void writeRow(std::ostringstream& s, const char* name, const std::vector<int64_t>& values) {
  s << name;
  for (int64_t n : values) s << " " << n;
  s << "\n";
}

}  // namespace

std::string OfflineRunSummary::text() const {
  std::ostringstream s;
  s << stats.text();
  if (!restart_note.empty()) s << "restart_note " << restart_note << "\n";
  writeRow(s, "nodes_by_session", nodes_by_session);
  writeRow(s, "nodes_in_mapped_area_by_session", nodes_in_mapped_area_by_session);
  writeRow(s, "nodes_new_heading_by_session", nodes_new_heading_by_session);
  writeRow(s, "nodes_new_place_by_session", nodes_new_place_by_session);
  writeRow(s, "nodes_near_a_view_by_session", nodes_near_a_view_by_session);
  writeRow(s, "views_by_session", views_by_session);
  s << "interfloor_pairs " << interfloor_pairs << "\ninterfloor_yaw_rms_deg "
    << interfloor_yaw_rms_deg << "\ninterfloor_yaw_claimed_deg " << interfloor_yaw_claimed_deg
    << "\n";
  writeRow(s, "pairs_by_session", pairs_by_session);
  writeRow(s, "pairs_between_earlier_nodes_by_session", pairs_between_earlier_nodes_by_session);
  writeRow(s, "steps_by_session", steps_by_session);
  writeRow(s, "steps_in_mapped_area_by_session", steps_in_mapped_area_by_session);
  s << "messages " << messages << "\ndecode_errors " << decode_errors << "\nfalse_matches "
    << false_matches << "\nsimulated_s " << duration_s << "\ndistance_m " << distance_m
    << "\nstep_poses " << step_poses << "\nate_rmse_m " << ate_rmse_m << "\nate_median_m "
    << ate_median_m << "\ntime_tracking_s " << stats.timing.tracking_s << "\ntime_registration_s "
    << stats.timing.registration_s << "\ntime_partition_s " << stats.timing.partition_s
    << "\ntime_solver_s " << stats.timing.solver_s << "\nbackground_batches "
    << stats.timing.background_batches << "\ntime_background_batch_s "
    << stats.timing.background_batch_s << "\ntime_background_wait_offline_s "
    << stats.timing.background_wait_s << "\nupdate_median_ms " << update_median_ms
    << "\nupdate_p99_ms " << update_p99_ms << "\nstep_median_ms " << step_median_ms
    << "\nstep_p99_ms " << step_p99_ms << "\nstep_p99_first_hour_ms " << step_p99_first_hour_ms
    << "\nstep_p99_last_hour_ms " << step_p99_last_hour_ms << "\nstep_cpu_p99_first_hour_ms "
    << step_cpu_p99_first_hour_ms << "\nstep_cpu_p99_last_hour_ms " << step_cpu_p99_last_hour_ms
    << "\nnodes_4h_before_end " << nodes_4h_before_end << "\nstore_transactions "
    << store_transactions << "\ntime_store_s " << store_s << "\noperating_h "
    << operating_s / 3600.0 << "\nstopped_early " << (stopped_early ? 1 : 0) << "\nwall_s "
    << wall_s << "\n";
  return s.str();
}

namespace {

// The run's figures from what the mapping did and saw.
Expected<OfflineRunSummary> summarise(OfflineMapping& mapping, const OfflineRunOptions& run) {
  const Mapper& mapper = mapping.mapper();
  OfflineRunSummary out;
  out.stopped_early = mapping.stoppedEarly();
  out.final_floor = mapper.floor();
  out.operating_s = mapping.operatingReachedS();
  out.store_transactions = mapping.storeTransactions();
  out.store_s = mapping.storeS();
  out.stats = mapper.stats();
  out.restored_nodes = mapper.stats().restored_nodes;
  out.restart_note = mapper.restartNote();
  out.nodes = static_cast<int64_t>(mapper.nodes().size());
  out.views_by_session = mapping.truth().views_by_session;
  std::vector<NodeTruth> node_truth = mapping.truth().nodes;
  node_truth.resize(mapper.nodes().size());
  countNodes(mapper, node_truth, run, &out);
  countSteps(mapper, mapping.truth(), node_truth, run, &out);
  countPairs(mapper, node_truth, &out);
  out.factors = mapper.stats().factors;
  out.constraints = static_cast<int64_t>(mapper.constraints().all().size());
  out.messages = mapping.broker().messages();
  out.decode_errors = mapping.broker().decodeErrors();
  out.false_matches = mapping.broker().falseMatches();
  out.duration_s = mapping.simulated().durationS();
  out.distance_m = mapping.simulated().distanceM();
  stepTimes(mapper, mapping.truth(), out.operating_s, &out);
  out.timeline = mapping.timeline().take();
  for (const TimelineRow& r : out.timeline) {
    if (r.operating_s > out.operating_s - 4 * 3600.0) break;
    out.nodes_4h_before_end = r.nodes;
  }
  out.wall_s = mapping.wallS();
  if (Status s = trajectoryErrors(mapper, mapping.truth(), node_truth, &out); !s) return s.error();
  return out;
}

}  // namespace

Expected<OfflineRunSummary> runOffline(const sim::SimOptions& sim_options, MapperOptions options,
                                       const std::filesystem::path& store_file) {
  OfflineRunOptions run;
  run.store_file = store_file;
  return runOffline(sim_options, std::move(options), run);
}

Expected<OfflineRunSummary> runOffline(const sim::SimOptions& sim_options, MapperOptions options,
                                       const OfflineRunOptions& run) {
  if (Status s = options.validate(); !s) return s.error();
  if (Status s = run.validate(); !s) return s.error();
  auto plan = sim::RunPlan::create(sim_options);
  if (!plan) return plan.error();
  const int last_session = run.last_session < 0 ? plan->sessions() - 1
                                                : std::min(run.last_session, plan->sessions() - 1);
  if (run.first_session > last_session)
    return makeError("offline run: sessions ", run.first_session, "-", last_session,
                     ": the run has ", plan->sessions());
  OfflineMapping mapping(sim_options, *plan, options, run);
  if (Status s = mapping.restore(); !s) return s.error();
  if (Status s = mapping.simulate(last_session); !s) return s.error();
  return summarise(mapping, run);
}

}  // namespace evermap::mapper
