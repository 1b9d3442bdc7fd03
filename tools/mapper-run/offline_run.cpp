#include "tools/mapper-run/offline_run.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <climits>
#include <tuple>
#include <functional>
#include <deque>
#include <map>
#include <numbers>
#include <optional>
#include <sstream>

#include <evermap/attitude_t.hpp>
#include <evermap/floor_t.hpp>
#include <evermap/vo_delta_t.hpp>
#include <evermap/wheel_odom_t.hpp>

#include "core/geometry/se2.h"
#include "core/messages/channels.h"
#include "core/messages/convert.h"
#include "mapper-proc/map_store.h"
#include "tools/eval/alignment.h"
#include "tools/eval/metrics.h"
#include "tools/mapper-run/run_metrics.h"
#include "tools/sim/registration_oracle.h"
#include "tools/sim/run.h"
#include "tools/sim/session_generator.h"

namespace evermap::mapper {
namespace {

// Feeds decoded messages to the mapper and brokers its requests with the oracle. Messages
// before `resume_utime` (a restored map) reach the mapper only when they are FLOOR messages;
// with `deliver` off none do (sessions simulated only for the oracle).
class Broker final : public sim::MessageSink {
 public:
  Broker(Mapper& mapper, sim::RegistrationOracle& oracle) : mapper_(mapper), oracle_(oracle) {}

  void write(const std::string& channel, int64_t utime, const std::vector<uint8_t>& data) override {
    if (!deliver_) return;
    const bool floor = channel == channels::kFloor;
    if (utime <= resume_utime_ && (!floor || !floors_before_resume_)) return;
    ++messages_;
    const int64_t size = static_cast<int64_t>(data.size());
    if (channel == channels::kVoDelta) {
      deliver(messages::decodeLcm<vo_delta_t>(data.data(), size, channel));
    } else if (channel == channels::kWheelOdom) {
      deliver(messages::decodeLcm<wheel_odom_t>(data.data(), size, channel));
    } else if (channel == channels::kAttitude) {
      deliver(messages::decodeLcm<attitude_t>(data.data(), size, channel));
    } else if (floor) {
      deliver(messages::decodeLcm<floor_t>(data.data(), size, channel));
    }
    pump();
    if (after_message_) after_message_(utime);
  }
  void setAfterMessage(std::function<void(int64_t)> f) { after_message_ = std::move(f); }
  void setOnNode(std::function<void(const node_added_t&)> f) { on_node_ = std::move(f); }
  void setDeliver(bool deliver) { deliver_ = deliver; }
  void setResumeUtime(int64_t utime, bool floors_before) {
    resume_utime_ = utime;
    floors_before_resume_ = floors_before;
  }

  // Called by the simulator's observer when a keyframe's truth is known.
  void keyframeKnown(int64_t utime) {
    known_keyframe_ = std::max(known_keyframe_, utime);
    pump();
  }

  int64_t messages() const { return messages_; }
  int64_t decodeErrors() const { return decode_errors_; }
  int64_t falseMatches() const { return false_matches_; }

 private:
  template <typename Msg>
  void deliver(const Expected<Msg>& msg) {
    if (!msg) {
      ++decode_errors_;
      return;
    }
    (void)apply(*msg);  // drops are counted by the mapper
  }
  Status apply(const vo_delta_t& m) { return mapper_.onVo(m); }
  Status apply(const wheel_odom_t& m) { return mapper_.onWheel(m); }
  Status apply(const attitude_t& m) { return mapper_.onAttitude(m); }
  Status apply(const floor_t& m) { return mapper_.onFloor(m); }

  // Nodes and requests wait until the oracle knows their keyframe; answers may raise new
  // requests (node mode, then global), so this loops until nothing is ready.
  void pump() {
    for (;;) {
      for (auto& n : mapper_.takeNodesAdded()) nodes_.push_back(n);
      for (auto& r : mapper_.takeRequests()) requests_.push_back(r);
      bool progressed = false;
      while (!nodes_.empty() && nodes_.front().keyframe_utime <= known_keyframe_) {
        oracle_.addNode(nodes_.front());
        if (on_node_) on_node_(nodes_.front());
        nodes_.pop_front();
        progressed = true;
      }
      if (!requests_.empty() && requests_.front().keyframe_utime <= known_keyframe_ &&
          nodes_.empty()) {
        const register_request_t r = requests_.front();
        requests_.pop_front();
        const auto answer = oracle_.answerWithTruth(r);
        if (answer.false_match) ++false_matches_;
        (void)mapper_.onRegisterResult(answer.result);
        progressed = true;
      }
      if (!progressed) return;
    }
  }

  Mapper& mapper_;
  sim::RegistrationOracle& oracle_;
  std::deque<node_added_t> nodes_;
  std::deque<register_request_t> requests_;
  int64_t known_keyframe_ = -1;
  int64_t messages_ = 0;
  int64_t decode_errors_ = 0;
  int64_t false_matches_ = 0;
  bool deliver_ = true;
  int64_t resume_utime_ = -1;
  bool floors_before_resume_ = true;
  std::function<void(int64_t)> after_message_;
  std::function<void(const node_added_t&)> on_node_;
};

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
  return Ok{};
}

std::string OfflineRunSummary::text() const {
  std::ostringstream s;
  s << stats.text();
  if (!restart_note.empty()) s << "restart_note " << restart_note << "\n";
  s << "nodes_by_session";
  for (int64_t n : nodes_by_session) s << " " << n;
  s << "\nnodes_in_mapped_area_by_session";
  for (int64_t n : nodes_in_mapped_area_by_session) s << " " << n;
  s << "\nnodes_new_heading_by_session";
  for (int64_t n : nodes_new_heading_by_session) s << " " << n;
  s << "\nnodes_new_place_by_session";
  for (int64_t n : nodes_new_place_by_session) s << " " << n;
  s << "\nnodes_near_a_view_by_session";
  for (int64_t n : nodes_near_a_view_by_session) s << " " << n;
  s << "\nviews_by_session";
  for (int64_t n : views_by_session) s << " " << n;
  s << "\ninterfloor_pairs " << interfloor_pairs << "\ninterfloor_yaw_rms_deg "
    << interfloor_yaw_rms_deg << "\ninterfloor_yaw_claimed_deg " << interfloor_yaw_claimed_deg;
  s << "\npairs_by_session";
  for (int64_t n : pairs_by_session) s << " " << n;
  s << "\npairs_between_earlier_nodes_by_session";
  for (int64_t n : pairs_between_earlier_nodes_by_session) s << " " << n;
  s << "\nsteps_by_session";
  for (int64_t n : steps_by_session) s << " " << n;
  s << "\nsteps_in_mapped_area_by_session";
  for (int64_t n : steps_in_mapped_area_by_session) s << " " << n;
  s << "\nmessages " << messages << "\ndecode_errors " << decode_errors << "\nfalse_matches "
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
  const auto wall_start = std::chrono::steady_clock::now();
  bool stopped_early = false;
  auto plan = sim::RunPlan::create(sim_options);
  if (!plan) return plan.error();
  const int last_session = run.last_session < 0 ? plan->sessions() - 1
                                                : std::min(run.last_session, plan->sessions() - 1);
  if (run.first_session > last_session)
    return makeError("offline run: sessions ", run.first_session, "-", last_session,
                     ": the run has ", plan->sessions());
  const core::SE3d body_T_cam = sim_options.sensors.camera.bodyTCam();
  options.tracker.body_T_cam = body_T_cam;
  Mapper mapper(options);
  sim::RegistrationOracle oracle(sim_options.oracle, plan->oracleSeed());
  Broker broker(mapper, oracle);
  std::map<int64_t, core::SE3d> truth;
  std::optional<MapStore> store;
  int64_t stored_nodes = 0, stored_constraints = 0, transactions = 0;
  double store_s = 0.0;
  Status store_status = Ok{};

  // A stored map: restored, its nodes told to the oracle as their keyframes come by.
  std::deque<node_added_t> stored_for_oracle;
  std::vector<NodeTruth> node_truth;
  int64_t resume_utime = -1;
  if (!run.store_file.empty()) {
    auto s = MapStore::open(run.store_file);
    if (!s) return s.error();
    store = std::move(*s);
    auto snapshot = store->load();
    if (!snapshot) return snapshot.error();
    if (Status r = mapper.restore(*snapshot); !r)
      return makeError(run.store_file.string(), ": ", r.error().message);
    std::vector<node_added_t> stored;
    for (const StoredNode& n : snapshot->nodes) {
      node_added_t m{};
      m.utime = m.keyframe_utime = n.node.keyframe_utime;
      m.node_id = n.node.id;
      m.floor = n.node.floor;
      m.session = n.node.session;
      stored.push_back(m);
      resume_utime = std::max(resume_utime, n.node.keyframe_utime);
      node_truth.push_back(NodeTruth{core::SE3d(), -1, n.node.session, false});
    }
    // Every update stored happened at or before its newest keyframe: resume after it.
    for (const StoredEdge& e : snapshot->edges)
      resume_utime = std::max(resume_utime, e.constraint.utime);
    // ... and after the saved tracking state; a live restart loses the messages of its gap.
    if (snapshot->tracking) resume_utime = std::max(resume_utime, snapshot->tracking->utime);
    if (resume_utime >= 0)
      resume_utime += static_cast<int64_t>(std::llround(run.restart_gap_s * 1e6));
    std::sort(stored.begin(), stored.end(), [](const node_added_t& a, const node_added_t& b) {
      return a.keyframe_utime < b.keyframe_utime;
    });
    stored_for_oracle.assign(stored.begin(), stored.end());
    stored_nodes = static_cast<int64_t>(mapper.nodes().size());
    stored_constraints = static_cast<int64_t>(mapper.constraints().all().size());
  }
  broker.setResumeUtime(resume_utime, run.floors_before_resume);

  std::vector<std::pair<int64_t, int>> step_floor;  // (keyframe utime, true floor), mapped part
  // Recent keyframe truths, for the true pose of each new node.
  std::deque<sim::KeyframeTruth> recent;
  broker.setOnNode([&](const node_added_t& n) {
    if (n.node_id >= static_cast<int64_t>(node_truth.size())) node_truth.resize(n.node_id + 1);
    NodeTruth& t = node_truth[n.node_id];
    t.session = n.session;
    auto it = std::lower_bound(recent.begin(), recent.end(), n.keyframe_utime,
                               [](const sim::KeyframeTruth& k, int64_t u) { return k.utime < u; });
    if (it != recent.end() && it->utime == n.keyframe_utime) {
      t.world_T_body = it->world_T_cam * body_T_cam.inverse();
      t.floor = it->floor;
      t.known = true;
    }
  });

  TimelineRecorder timeline(mapper, run.timeline_interval_s);
  // The views the keyframes' true poses need at the overlap's radius (a cell at least) and a
  // heading sector (the overlap's tolerance by default, and its largest).
  ViewCover views(std::max(1.0, options.overlap_radius_cells) * options.cell_size_m,
                  2.0 * std::numbers::pi / options.heading_bins);
  timeline.setViewProbe([&] { return views.views(); });
  std::vector<int64_t> views_by_session;
  if (store) {
    timeline.setStoreProbe([&](TimelineRow* r) {
      if (auto rows = store->edgeRows()) r->store_rows = *rows;
      std::error_code ec;
      int64_t bytes = 0;
      for (const char* suffix : {"", "-wal"}) {
        const auto n = std::filesystem::file_size(run.store_file.string() + suffix, ec);
        if (!ec) bytes += static_cast<int64_t>(n);
      }
      r->store_bytes = bytes;
    });
  }
  double operating_before_s = 0.0;  // mapped sessions finished
  int64_t session_start = -1;
  int current_session = 0;
  auto operating = [&](int64_t utime) {
    return operating_before_s +
           (session_start < 0 ? 0.0 : 1e-6 * static_cast<double>(utime - session_start));
  };
  int64_t messages_seen = 0;
  std::vector<std::pair<int64_t, double>> session_offsets;  // (start utime, operating time then)
  double next_store_s = 0.0;                                // OfflineRunOptions::store_period_s
  int64_t tracked_steps = 0;
  auto saveStore = [&](int64_t utime) {
    const auto nodes = static_cast<int64_t>(mapper.nodes().size());
    const auto constraints = static_cast<int64_t>(mapper.constraints().all().size());
    if (!store_status) return;
    if (nodes == stored_nodes && constraints == stored_constraints) {
      // The tracking state alone, once per step, as mapper-proc (a failure costs a warm
      // restart at most).
      if (mapper.stats().steps == tracked_steps) return;
      tracked_steps = mapper.stats().steps;
      (void)store->saveTracking(mapper);
      return;
    }
    tracked_steps = mapper.stats().steps;
    const auto t0 = std::chrono::steady_clock::now();
    store_status = store->save(mapper, mapper.session(), session_start);
    store_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    stored_nodes = nodes;
    stored_constraints = constraints;
    ++transactions;
    if (store_status && run.on_commit) {
      auto rows = store->edgeRows();
      if (!rows)
        store_status = rows.error();
      else
        run.on_commit(StoreCommit{nodes, constraints, *rows, utime});
    }
  };
  broker.setAfterMessage([&](int64_t utime) {
    if (session_start < 0) {
      session_start = utime;
      session_offsets.emplace_back(utime, operating_before_s);
    }
    timeline.sample(operating(utime), utime, current_session);
    if (run.stop_after_s > 0 && !stopped_early && operating(utime) >= run.stop_after_s) {
      stopped_early = true;
      broker.setDeliver(false);
    }
    if (run.max_wall_s > 0 && ++messages_seen % 1000 == 0 &&
        std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count() >
            run.max_wall_s) {
      stopped_early = true;
      broker.setDeliver(false);
    }
    if (!store) return;
    if (run.store_period_s > 0) {
      if (operating(utime) < next_store_s) return;
      next_store_s = operating(utime) + run.store_period_s;
    }
    saveStore(utime);
  });

  sim::SessionObservers observers;
  observers.on_keyframe = [&](const sim::KeyframeTruth& k) {
    oracle.addKeyframe(k);
    if (views.add(k.floor, k.world_T_cam * body_T_cam.inverse())) {
      if (current_session >= static_cast<int>(views_by_session.size()))
        views_by_session.resize(current_session + 1, 0);
      ++views_by_session[current_session];
    }
    if (k.utime > resume_utime && current_session >= run.first_session)
      step_floor.emplace_back(k.utime, k.floor);
    recent.push_back(k);
    while (recent.size() > 2 && recent.front().utime < k.utime - 120'000'000) recent.pop_front();
    while (!stored_for_oracle.empty() && stored_for_oracle.front().keyframe_utime <= k.utime) {
      const node_added_t& n = stored_for_oracle.front();
      oracle.addNode(n);
      if (n.keyframe_utime == k.utime) {
        node_truth[n.node_id] =
            NodeTruth{k.world_T_cam * body_T_cam.inverse(), k.floor, n.session, true};
      }
      stored_for_oracle.pop_front();
    }
    broker.keyframeKnown(k.utime);
  };
  observers.on_ground_truth = [&](int64_t utime, const sim::BodyState& b) {
    if (utime > resume_utime && current_session >= run.first_session) truth[utime] = b.world_T_body;
  };
  sim::RunSummary summary_run;
  // Sessions before the mapped ones are simulated only when a stored map needs their keyframes.
  const int first_generated = stored_for_oracle.empty() ? run.first_session : 0;
  double operating_reached_s = 0.0;
  for (int i = first_generated; i <= last_session; ++i) {
    if (!store_status || stopped_early) break;
    current_session = i;
    const bool mapped = i >= run.first_session;
    broker.setDeliver(mapped);
    session_start = -1;
    const sim::SessionSummary ss =
        sim::generateSession(plan->building(), plan->session(i), sim_options.sensors,
                             sim_options.seed, broker, observers);
    if (mapped) {
      summary_run.sessions.push_back(ss);
      operating_reached_s = operating(stopped_early ? mapper.tracker().lastUtime() : ss.end_utime);
      if (session_start >= 0) operating_before_s = operating(ss.end_utime);
    }
  }
  if (store && run.store_period_s > 0)
    saveStore(mapper.tracker().lastUtime());  // what the last period left
  timeline.sample(operating_reached_s, mapper.tracker().lastUtime(), current_session, true);

  if (!store_status) return store_status.error();
  OfflineRunSummary out;
  out.stopped_early = stopped_early;
  out.final_floor = mapper.floor();
  out.operating_s = operating_reached_s;
  out.store_transactions = transactions;
  out.store_s = store_s;
  out.stats = mapper.stats();
  out.restored_nodes = mapper.stats().restored_nodes;
  out.restart_note = mapper.restartNote();
  out.nodes = mapper.graphNodes();
  out.views_by_session = std::move(views_by_session);
  for (const MapperNode& n : mapper.nodes()) {
    if (n.session >= static_cast<int>(out.nodes_by_session.size()))
      out.nodes_by_session.resize(n.session + 1, 0);
    ++out.nodes_by_session[n.session];
  }
  node_truth.resize(mapper.nodes().size());
  {
    const std::vector<PlaceCause> causes =
        placeCauses(node_truth, node_truth, run.revisit_radius_m, run.revisit_angle_rad);
    // The same test at twice the radius and angle (2 m, 45°: the partition's sector).
    const std::vector<PlaceCause> near = placeCauses(
        node_truth, node_truth, 2.0 * run.revisit_radius_m, 2.0 * run.revisit_angle_rad);
    for (auto* v : {&out.nodes_in_mapped_area_by_session, &out.nodes_new_heading_by_session,
                    &out.nodes_new_place_by_session, &out.nodes_near_a_view_by_session})
      v->assign(out.nodes_by_session.size(), 0);
    for (size_t k = 0; k < causes.size(); ++k) {
      const auto s = static_cast<size_t>(mapper.nodes()[k].session);
      if (s >= out.nodes_by_session.size()) continue;
      if (causes[k] == PlaceCause::kMapped) ++out.nodes_in_mapped_area_by_session[s];
      if (causes[k] == PlaceCause::kNewHeading) ++out.nodes_new_heading_by_session[s];
      if (causes[k] == PlaceCause::kNewPlace) ++out.nodes_new_place_by_session[s];
      if (causes[k] != PlaceCause::kMapped && near[k] == PlaceCause::kMapped)
        ++out.nodes_near_a_view_by_session[s];
    }
  }
  {
    // Where the robot was at each step, against the same nodes: how much of each session
    // went through areas mapped before it.
    std::vector<NodeTruth> steps;
    for (const auto& p : mapper.stepPoses()) {
      if (truth.empty()) break;
      NodeTruth t{truthAt(truth, p.utime), -1, p.session, false};
      auto it =
          std::lower_bound(step_floor.begin(), step_floor.end(), std::make_pair(p.utime, INT_MIN));
      if (it != step_floor.end() && it->first == p.utime) {
        t.floor = it->second;
        t.known = true;
      }
      steps.push_back(t);
      if (p.session >= static_cast<int>(out.steps_by_session.size()))
        out.steps_by_session.resize(p.session + 1, 0);
      ++out.steps_by_session[p.session];
    }
    out.steps_in_mapped_area_by_session =
        inMappedArea(node_truth, steps, run.revisit_radius_m, run.revisit_angle_rad);
    out.steps_in_mapped_area_by_session.resize(out.steps_by_session.size(), 0);
  }
  {
    // One pass over the node pairs: those between floors against the truth, and the session
    // each was opened in (that of the step at or after its first constraint).
    const auto& poses = mapper.stepPoses();
    const size_t sessions = out.nodes_by_session.size();
    for (auto* v : {&out.pairs_by_session, &out.pairs_between_earlier_nodes_by_session})
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
          ++out.interfloor_pairs;
        }
      }
      const int64_t utime = mapper.constraints().all()[pair.members.front()].utime;
      auto it = std::lower_bound(poses.begin(), poses.end(), utime,
                                 [](const Mapper::StepPose& p, int64_t t) { return p.utime < t; });
      if (it == poses.end()) --it;
      const auto s = static_cast<size_t>(it->session);
      if (s >= sessions) continue;
      ++out.pairs_by_session[s];
      const int last =
          std::max(mapper.nodes()[key.first].session, mapper.nodes()[key.second].session);
      if (last < it->session) ++out.pairs_between_earlier_nodes_by_session[s];
    }
    if (out.interfloor_pairs > 0) {
      const double n = static_cast<double>(out.interfloor_pairs);
      out.interfloor_yaw_rms_deg = std::sqrt(yaw2 / n) * 180.0 / std::numbers::pi;
      out.interfloor_yaw_claimed_deg = std::sqrt(claimed2 / n) * 180.0 / std::numbers::pi;
    }
  }
  out.factors = mapper.stats().factors;
  out.constraints = static_cast<int64_t>(mapper.constraints().all().size());
  out.messages = broker.messages();
  out.decode_errors = broker.decodeErrors();
  out.false_matches = broker.falseMatches();
  out.duration_s = summary_run.durationS();
  out.distance_m = summary_run.distanceM();
  std::vector<double> ms;
  for (double s : mapper.stats().timing.update_s) ms.push_back(1e3 * s);
  out.update_median_ms = percentile(ms, 0.5);
  out.update_p99_ms = percentile(ms, 0.99);
  {
    std::vector<double> all, first_hour, last_hour, first_hour_cpu, last_hour_cpu;
    for (const auto& c : mapper.stats().timing.step_cost) {
      auto it = std::upper_bound(session_offsets.begin(), session_offsets.end(),
                                 std::make_pair(c.utime, 1e300));
      if (it == session_offsets.begin()) continue;
      --it;
      const double t = it->second + 1e-6 * static_cast<double>(c.utime - it->first);
      all.push_back(1e3 * c.s);
      if (t < 3600.0) first_hour.push_back(1e3 * c.s);
      if (t >= operating_reached_s - 3600.0) last_hour.push_back(1e3 * c.s);
      if (t < 3600.0) first_hour_cpu.push_back(1e3 * c.cpu_s);
      if (t >= operating_reached_s - 3600.0) last_hour_cpu.push_back(1e3 * c.cpu_s);
    }
    out.step_median_ms = percentile(all, 0.5);
    out.step_p99_ms = percentile(all, 0.99);
    out.step_p99_first_hour_ms = percentile(first_hour, 0.99);
    out.step_p99_last_hour_ms = percentile(last_hour, 0.99);
    out.step_cpu_p99_first_hour_ms = percentile(first_hour_cpu, 0.99);
    out.step_cpu_p99_last_hour_ms = percentile(last_hour_cpu, 0.99);
  }
  out.timeline = timeline.take();
  for (const TimelineRow& r : out.timeline) {
    if (r.operating_s > operating_reached_s - 4 * 3600.0) break;
    out.nodes_4h_before_end = r.nodes;
  }

  std::vector<core::SE3d> gt, est;
  for (const auto& p : mapper.stepPoses()) {
    if (truth.empty()) break;
    gt.push_back(truthAt(truth, p.utime));
    est.push_back(mapper.nodePose(p.node) * p.node_T_body);
  }
  out.step_poses = static_cast<int64_t>(est.size());
  out.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  if (est.size() < 3) return out;  // too little mapped (a run resumed at its very end)
  auto aligned = eval::alignTrajectories(gt, est, eval::AlignmentMode::kSE3);
  if (!aligned) return makeError("offline run: ATE: ", aligned.error().message);
  for (auto& e : est) e = aligned->gt_S_est * e;
  auto ate = eval::computeAte(gt, est);
  if (!ate) return makeError("offline run: ATE: ", ate.error().message);
  out.ate_rmse_m = ate->translation_m.rmse;
  out.ate_median_m = ate->translation_m.median;
  for (size_t k = 0; k < gt.size(); ++k) {
    out.trajectory_gt.push_back(gt[k].translation());
    out.trajectory_est.push_back(est[k].translation());
    const Mapper::StepPose& p = mapper.stepPoses()[k];
    auto fl =
        std::lower_bound(step_floor.begin(), step_floor.end(), std::make_pair(p.utime, INT_MIN));
    const int floor = fl != step_floor.end() && fl->first == p.utime ? fl->second : -1;
    out.step_errors.push_back({p.utime, p.session, p.node, floor,
                               (gt[k].translation() - est[k].translation()).norm(),
                               core::toPlanar(gt[k].inverse() * est[k]).theta() * 180.0 / M_PI});
  }
  for (const MapperNode& n : mapper.nodes()) {
    if (n.id >= static_cast<int64_t>(node_truth.size()) || !node_truth[n.id].known) continue;
    out.nodes_gt.push_back(node_truth[n.id].world_T_body.translation());
    out.nodes_est.push_back((aligned->gt_S_est * mapper.nodePose(n.id)).translation());
    out.node_errors.push_back({n.id, n.session, n.floor, n.keyframe_utime,
                               (out.nodes_gt.back() - out.nodes_est.back()).norm(),
                               node_truth[n.id].world_T_body});
  }
  return out;
}

}  // namespace evermap::mapper
