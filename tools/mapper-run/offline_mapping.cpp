#include "tools/mapper-run/offline_mapping.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

#include "tools/mapper-run/store_bytes.h"

namespace evermap::mapper {
namespace {

MapperOptions withCamera(MapperOptions options, const core::SE3d& body_T_cam) {
  options.tracker.body_T_cam = body_T_cam;
  return options;
}

}  // namespace

OfflineMapping::OfflineMapping(const sim::SimOptions& sim, const sim::RunPlan& plan,
                               const MapperOptions& options, const OfflineRunOptions& run)
    : sim_(sim),
      plan_(plan),
      run_(run),
      body_T_cam_(sim.sensors.camera.bodyTCam()),
      mapper_(withCamera(options, body_T_cam_)),
      oracle_(sim.oracle, plan.oracleSeed()),
      broker_(mapper_, oracle_),
      timeline_(mapper_, run.timeline_interval_s),
      // The views the keyframes' true poses need at the overlap's radius (a cell at least)
      // and a heading sector (the overlap's tolerance by default, and its largest).
      views_(std::max(1.0, options.overlap_radius_cells) * options.cell_size_m,
             2.0 * std::numbers::pi / options.heading_bins),
      wall_start_(std::chrono::steady_clock::now()) {
  if (run.progress_period_s > 0.0)
    progress_.emplace(
        std::string("evermap-mapper-run, ") + (options.full_graph ? "full" : "reduced") + " graph",
        "steps", printToStderr, run.progress_period_s);
}

double OfflineMapping::wallS() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start_).count();
}

Status OfflineMapping::restore() {
  if (!run_.store_file.empty()) {
    auto s = MapStore::open(run_.store_file);
    if (!s) return s.error();
    store_ = std::move(*s);
    auto snapshot = store_->load();
    if (!snapshot) return snapshot.error();
    if (Status r = mapper_.restore(*snapshot); !r)
      return makeError(run_.store_file.string(), ": ", r.error().message);
    std::vector<node_added_t> stored;
    for (const StoredNode& n : snapshot->nodes) {
      node_added_t m{};
      m.utime = m.keyframe_utime = n.node.keyframe_utime;
      m.node_id = n.node.id;
      m.floor = n.node.floor;
      m.session = n.node.session;
      stored.push_back(m);
      resume_utime_ = std::max(resume_utime_, n.node.keyframe_utime);
      truth_.nodes.push_back(NodeTruth{core::SE3d(), -1, n.node.session, false});
    }
    // Every update stored happened at or before its newest keyframe: resume after it.
    for (const StoredEdge& e : snapshot->edges)
      resume_utime_ = std::max(resume_utime_, e.constraint.utime);
    // ... and after the saved tracking state; a live restart loses the messages of its gap.
    if (snapshot->tracking) resume_utime_ = std::max(resume_utime_, snapshot->tracking->utime);
    if (resume_utime_ >= 0)
      resume_utime_ += static_cast<int64_t>(std::llround(run_.restart_gap_s * 1e6));
    std::sort(stored.begin(), stored.end(), [](const node_added_t& a, const node_added_t& b) {
      return a.keyframe_utime < b.keyframe_utime;
    });
    stored_for_oracle_.assign(stored.begin(), stored.end());
    stored_nodes_ = static_cast<int64_t>(mapper_.nodes().size());
    stored_constraints_ = static_cast<int64_t>(mapper_.constraints().all().size());
  }
  broker_.setResumeUtime(resume_utime_, run_.floors_before_resume);
  broker_.setOnNode([this](const node_added_t& n) { onNode(n); });
  timeline_.setViewProbe([this] { return views_.views(); });
  if (store_) watchStore();
  broker_.setAfterMessage([this](int64_t utime) { afterMessage(utime); });
  return Ok{};
}

void OfflineMapping::watchStore() {
  timeline_.setStoreProbe([this](TimelineRow* r) {
    if (auto rows = store_->edgeRows()) r->store_rows = *rows;
    r->store_bytes = storeFileBytes(run_.store_file);
  });
}

Status OfflineMapping::simulate(int last_session) {
  sim::SessionObservers observers;
  observers.on_keyframe = [this](const sim::KeyframeTruth& k) { onKeyframe(k); };
  observers.on_ground_truth = [this](int64_t utime, const sim::BodyState& b) {
    if (utime > resume_utime_ && current_session_ >= run_.first_session)
      truth_.world_T_body[utime] = b.world_T_body;
  };
  // Sessions before the mapped ones are simulated only when a stored map needs their keyframes.
  first_generated_ = stored_for_oracle_.empty() ? run_.first_session : 0;
  last_session_ = last_session;
  for (int i = first_generated_; i <= last_session; ++i) {
    if (!store_status_ || stopped_early_) break;
    current_session_ = i;
    const bool mapped = i >= run_.first_session;
    broker_.setDeliver(mapped);
    session_start_ = -1;
    const sim::SessionPlan session = plan_.session(i);
    trajectory_start_ = session.trajectory->startUtime();
    trajectory_end_ = session.trajectory->endUtime();
    const sim::SessionSummary ss = sim::generateSession(plan_.building(), session, sim_.sensors,
                                                        sim_.seed, broker_, observers);
    if (mapped) {
      simulated_.sessions.push_back(ss);
      operating_reached_s_ =
          operating(stopped_early_ ? mapper_.tracker().lastUtime() : ss.end_utime);
      if (session_start_ >= 0) operating_before_s_ = operating(ss.end_utime);
    }
  }
  if (store_ && run_.store_period_s > 0)
    saveStore(mapper_.tracker().lastUtime());  // what the last period left
  timeline_.sample(operating_reached_s_, mapper_.tracker().lastUtime(), current_session_, true);
  return store_status_;
}

void OfflineMapping::onNode(const node_added_t& n) {
  std::vector<NodeTruth>& nodes = truth_.nodes;
  if (n.node_id >= static_cast<int64_t>(nodes.size())) nodes.resize(n.node_id + 1);
  NodeTruth& t = nodes[n.node_id];
  t.session = n.session;
  auto it = std::lower_bound(recent_.begin(), recent_.end(), n.keyframe_utime,
                             [](const sim::KeyframeTruth& k, int64_t u) { return k.utime < u; });
  if (it != recent_.end() && it->utime == n.keyframe_utime) {
    t.world_T_body = it->world_T_cam * body_T_cam_.inverse();
    t.floor = it->floor;
    t.known = true;
  }
}

void OfflineMapping::onKeyframe(const sim::KeyframeTruth& k) {
  oracle_.addKeyframe(k);
  if (views_.add(k.floor, k.world_T_cam * body_T_cam_.inverse())) {
    std::vector<int64_t>& views = truth_.views_by_session;
    if (current_session_ >= static_cast<int>(views.size())) views.resize(current_session_ + 1, 0);
    ++views[current_session_];
  }
  if (k.utime > resume_utime_ && current_session_ >= run_.first_session)
    truth_.step_floor.emplace_back(k.utime, k.floor);
  recent_.push_back(k);
  while (recent_.size() > 2 && recent_.front().utime < k.utime - 120'000'000) recent_.pop_front();
  while (!stored_for_oracle_.empty() && stored_for_oracle_.front().keyframe_utime <= k.utime) {
    const node_added_t& n = stored_for_oracle_.front();
    oracle_.addNode(n);
    if (n.keyframe_utime == k.utime) {
      truth_.nodes[n.node_id] =
          NodeTruth{k.world_T_cam * body_T_cam_.inverse(), k.floor, n.session, true};
    }
    stored_for_oracle_.pop_front();
  }
  broker_.keyframeKnown(k.utime);
}

double OfflineMapping::operating(int64_t utime) const {
  return operating_before_s_ +
         (session_start_ < 0 ? 0.0 : 1e-6 * static_cast<double>(utime - session_start_));
}

void OfflineMapping::afterMessage(int64_t utime) {
  if (session_start_ < 0) {
    session_start_ = utime;
    truth_.session_offsets.emplace_back(utime, operating_before_s_);
  }
  timeline_.sample(operating(utime), utime, current_session_);
  if (run_.stop_after_s > 0 && !stopped_early_ && operating(utime) >= run_.stop_after_s) {
    stopped_early_ = true;
    broker_.setDeliver(false);
  }
  if (run_.max_wall_s > 0 && ++messages_seen_ % 1000 == 0 && wallS() > run_.max_wall_s) {
    stopped_early_ = true;
    broker_.setDeliver(false);
  }
  if (progress_) progress_->update(progressAt(utime));
  if (!store_) return;
  if (run_.store_period_s > 0) {
    if (operating(utime) < next_store_s_) return;
    next_store_s_ = operating(utime) + run_.store_period_s;
  }
  saveStore(utime);
}

Progress OfflineMapping::progressAt(int64_t utime) const {
  Progress p;
  p.data_done_s = operating(utime);
  const double in_session = trajectory_end_ > trajectory_start_
                                ? static_cast<double>(utime - trajectory_start_) /
                                      static_cast<double>(trajectory_end_ - trajectory_start_)
                                : 0.0;
  p.fraction = (current_session_ - first_generated_ + std::clamp(in_session, 0.0, 1.0)) /
               (last_session_ - first_generated_ + 1);
  if (run_.stop_after_s > 0) p.fraction = std::max(p.fraction, p.data_done_s / run_.stop_after_s);
  p.steps = mapper_.stats().steps;
  p.nodes = static_cast<int64_t>(mapper_.nodes().size());
  return p;
}

void OfflineMapping::saveStore(int64_t utime) {
  const auto nodes = static_cast<int64_t>(mapper_.nodes().size());
  const auto constraints = static_cast<int64_t>(mapper_.constraints().all().size());
  if (!store_status_) return;
  if (nodes == stored_nodes_ && constraints == stored_constraints_) {
    // The tracking state alone, once per step, as mapper-proc (a failure costs a warm
    // restart at most).
    if (mapper_.stats().steps == tracked_steps_) return;
    tracked_steps_ = mapper_.stats().steps;
    (void)store_->saveTracking(mapper_);
    return;
  }
  tracked_steps_ = mapper_.stats().steps;
  const auto t0 = std::chrono::steady_clock::now();
  store_status_ = store_->save(mapper_, mapper_.session(), session_start_);
  store_s_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  stored_nodes_ = nodes;
  stored_constraints_ = constraints;
  ++transactions_;
  if (store_status_ && run_.on_commit) {
    auto rows = store_->edgeRows();
    if (!rows)
      store_status_ = rows.error();
    else
      run_.on_commit(StoreCommit{nodes, constraints, *rows, utime});
  }
}

}  // namespace evermap::mapper
