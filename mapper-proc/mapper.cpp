#include "mapper-proc/mapper.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "core/common/clocks.h"

namespace evermap::mapper {

Mapper::Mapper(const MapperOptions& options, int session)
    : MapConsumer(options.tracker),
      o_(options),
      session_(session),
      first_session_(session),
      partition_({options.cell_size_m, options.heading_bins, options.overlap_radius_cells,
                  options.overlap_heading_sectors, options.cell_refresh_per_step}),
      footprints_({options.cell_size_m, options.heading_bins}, options.cell_refresh_per_step),
      constraints_(options.consistency_gate),
      schedule_(options.solver, options.defer_merges, options.covariance_floor),
      map_gate_(options.map_gate),
      recovery_(options),
      floors_(options.floor_match_m, options.floor_gate),
      warm_(options) {}

Status Mapper::onVo(const vo_delta_t& msg) {
  // A keyframe step the tracker held for its heading is taken before VO moves on; after a
  // session's gap, without the mapper's step (it would belong to the session before).
  const bool session_gap =
      last_vo_utime_ >= 0 && msg.utime - last_vo_utime_ > micros(o_.session_gap_s);
  takeHeldStep(msg.utime, session_gap);
  if (warm_.pending() && warm_.waitForWheels(msg, tracker_)) {
    ++stats_.warm_wheel_waits;
    return Ok{};
  }
  const auto t0 = SteadyClock::now();
  const Status s = tracker_.addVo(msg);
  stats_.timing.tracking_s += secondsSince(t0);
  if (!s) {
    ++stats_.dropped;
    return s;
  }
  if (warm_.pending()) {
    const auto r =
        warm_.decide(msg, tracker_, RestoredMap{nodes_, constraints_, schedule_}, stats_);
    if (r) resume(*r);
  }
  checkTimeout(msg.utime);
  if (session_gap) startSession(msg.utime);
  last_vo_utime_ = msg.utime;
  if (msg.keyframe_changed) stepAtKeyframe(msg.utime);
  return Ok{};
}

void Mapper::stepAtKeyframe(int64_t keyframe_utime) {
  // A step at a keyframe the tracker now chains from (a chain break's new reference too); not
  // at one it holds for its heading (TrackerOptions::heading_wait_s), which comes here when
  // the tracker takes it.
  if (tracker_.referenceUtime() == keyframe_utime && !in_flight_ && !floors_.inElevator() &&
      (last_step_utime_ < 0 || keyframe_utime - last_step_utime_ >= micros(o_.step_interval_s)))
    step(keyframe_utime);
}

void Mapper::takeHeldStep(int64_t now_utime, bool session_starts) {
  const auto keyframe_utime = tracker_.takeHeldStep();
  // Not when a session starts (the step belongs to the one before), nor when its request
  // would be timed out at once (the streams stopped while it waited).
  if (keyframe_utime && !session_starts &&
      now_utime - *keyframe_utime <= micros(o_.request_timeout_s))
    stepAtKeyframe(*keyframe_utime);
}

void Mapper::startSession(int64_t utime) {
  if (!floors_.known() || active_ < 0) return;  // nothing mapped yet: the first session goes on
  // The FLOOR message and the VO gap both announce a session: one session per gap.
  if (lost_ && session_start_utime_ >= 0 &&
      std::abs(utime - session_start_utime_) < micros(o_.session_gap_s))
    return;
  relocalization_candidate_.reset();
  recovery_.rejected().reset();
  ++session_;
  session_start_utime_ = utime;
  if (!map_confirmed_) {
    // Nothing of the map was ever confirmed: no place to re-localise on, and waiting for one
    // would map nothing (issue 47: a phantom node from fuzzed odometry, then 0 nodes).
    quarantineOrigin();
    lost_ = false;
    return;
  }
  // Where the robot is relative to the map is unknown until a global registration
  // re-localises it (DESIGN.md section 3).
  lost_ = true;
}

void Mapper::quarantineOrigin() {
  quarantined_.resize(nodes_.size(), false);
  int64_t count = 0;
  int origin_session = -1;
  for (const MapperNode& n : nodes_) {
    if (quarantined_[static_cast<size_t>(n.id)]) continue;
    quarantined_[static_cast<size_t>(n.id)] = true;
    partition_.quarantine(n.id);
    footprints_.forget(n.id);
    floors_.nodesOn(n.floor, -1);
    if (origin_session < 0) origin_session = n.session;
    ++count;
  }
  ++stats_.sessions_quarantined;
  stats_.nodes_quarantined += count;
  notes_.push_back(
      "session " + std::to_string(origin_session) + " quarantined: " + std::to_string(count) +
      " nodes no registration confirmed; session " + std::to_string(session_) +
      " starts the map afresh (" + std::to_string(stats_.sessions_quarantined) + " quarantined)");
  // The next step's node is the new origin; a step still open belonged to the session before.
  active_ = -1;
  in_flight_.reset();
  relocalize_ = false;
  tracker_.reset(core::UncertainPose{});
}

Status Mapper::onWheel(const wheel_odom_t& msg) {
  if (tracker_.heldStepDue(msg.utime)) takeHeldStep(msg.utime);
  const auto t0 = SteadyClock::now();
  const Status s = tracker_.addWheel(msg);
  stats_.timing.tracking_s += secondsSince(t0);
  if (!s) ++stats_.dropped;
  return s;
}

Status Mapper::onAttitude(const attitude_t& msg) {
  const bool finite = std::isfinite(msg.roll_rad) && std::isfinite(msg.pitch_rad) &&
                      std::isfinite(msg.covariance[0]) && std::isfinite(msg.covariance[1]) &&
                      std::isfinite(msg.covariance[2]) && std::isfinite(msg.covariance[3]);
  const double det = msg.covariance[0] * msg.covariance[3] - msg.covariance[1] * msg.covariance[2];
  if (!finite || msg.utime <= last_attitude_utime_ || !(msg.covariance[0] > 0.0) ||
      !(msg.covariance[3] > 0.0) || !(det > 0.0) ||
      std::abs(msg.covariance[1] - msg.covariance[2]) >
          1e-9 * std::max(msg.covariance[0], msg.covariance[3])) {
    ++stats_.dropped;
    return makeError("ATTITUDE ", msg.utime, ": not finite, out of order or not a covariance");
  }
  last_attitude_utime_ = msg.utime;
  if (msg.accel_trusted) attitude_ = msg;
  const Status s = tracker_.addHeading(msg);
  if (tracker_.heldStepCovered()) takeHeldStep(msg.utime);
  return s;
}

Status Mapper::onFloor(const floor_t& msg) {
  // The first sign of a ride, and its all-clear: the mapper acts on the confirmed start
  // (its steps before it are held or made as without the sign).
  if (msg.event == floor_t::EVENT_VERTICAL_MOTION || msg.event == floor_t::EVENT_VERTICAL_STILL)
    return Ok{};
  // A ride's start stops the steps after it, not one held before it; a session's start
  // (EVENT_NONE) ends the session the held step belongs to: no mapper step then.
  takeHeldStep(msg.utime, msg.event == floor_t::EVENT_NONE);
  bool implausible = false;
  if (Status s = floors_.check(msg, &implausible); !s) {
    ++stats_.dropped;
    if (implausible) ++stats_.implausible_floors;
    return s;
  }
  // A ride or a session announced after a saved tracking state: no warm restart from it.
  warm_.onFloor(msg, stats_);
  if (msg.event == floor_t::EVENT_RIDE_START) {
    floors_.rideStarts(msg);
    stats_.floor_heights_replaced = floors_.heightsReplaced();
    return Ok{};
  }
  if (msg.event == floor_t::EVENT_NONE) startSession(msg.utime);
  if (floors_.known() && msg.event == floor_t::EVENT_RIDE_END && active_ >= 0) {
    // The ride's vertical displacement, as far as odometry has not seen it already (VO may
    // track through the cab; wheels never do): the estimate is moved to the measured height.
    tracker_.addHeight(msg.height_m - pose().mean.translation().z(),
                       std::max(msg.height_sigma_m, 0.01));
  }
  floors_.reach(msg);
  stats_.floor_heights_replaced = floors_.heightsReplaced();
  return Ok{};
}

std::vector<node_added_t> Mapper::takeNodesAdded() { return std::exchange(nodes_added_, {}); }
std::vector<std::string> Mapper::takeNotes() {
  for (std::string& line : floors_.takeNotes()) notes_.push_back(std::move(line));
  return std::exchange(notes_, {});
}

core::UncertainPose Mapper::pose() const {
  core::UncertainPose p = tracker_.delta();
  if (active_ >= 0) p.mean = nodePose(active_) * p.mean;
  return p;
}

void Mapper::addStepCost(SteadyClock::time_point t0, double c0) {
  step_cost_s_ += secondsSince(t0);
  step_cpu_s_ += threadCpuSeconds() - c0;
}

void Mapper::step(int64_t keyframe_utime) {
  const auto t0 = SteadyClock::now();
  const double c0 = threadCpuSeconds();
  ++stats_.steps;
  last_step_utime_ = keyframe_utime;
  step_cost_s_ = 0.0;
  step_cpu_s_ = 0.0;
  if (active_ < 0) {  // the first node (or the first after a quarantine): the origin
    addNode(keyframe_utime, core::UncertainPose{});
    tracker_.reset(tracker_.sinceKeyframe(keyframe_utime).value_or(core::UncertainPose{}));
    flushSolver();
    step_poses_.push_back(StepPose{keyframe_utime, active_, core::SE3d(), session_});
    stats_.timing.step_cost.push_back({keyframe_utime, secondsSince(t0), threadCpuSeconds() - c0});
    return;
  }
  InFlight f;
  f.keyframe_utime = keyframe_utime;
  f.sent_utime = keyframe_utime;
  if (o_.full_graph && !lost_) {
    // The baseline: a node at every step, chained by the tracked motion.
    addNode(keyframe_utime, tracker_.delta());
    tracker_.reset(core::UncertainPose{});
    flushSolver();
  }
  f.active = active_;
  f.delta_at_keyframe = tracker_.delta();
  in_flight_ = f;
  const auto target = stepTarget(keyframe_utime, nodePose(active_) * f.delta_at_keyframe.mean);
  if (target)
    sendRequest(register_request_t::MODE_NODE, *target);
  else
    sendRequest(register_request_t::MODE_GLOBAL, -1);
  addStepCost(t0, c0);
}

std::optional<int64_t> Mapper::stepTarget(int64_t keyframe_utime, const core::SE3d& world_T_body) {
  if (lost_) return relocalizationCheck(keyframe_utime);
  // A warm restart's candidate placement, checked where it predicts the robot is.
  if (warm_.unconfirmed())
    if (auto check = relocalizationCheck(keyframe_utime)) return check;
  if (o_.full_graph)
    return partition_.nodeInCell(partition_.cellOf(world_T_body, floors_.floor()),
                                 keyframe_utime - micros(o_.recent_exclusion_s), nodes_);
  if (auto node = nodeAt(world_T_body, floors_.floor(), keyframe_utime)) return node;
  // The active node, unless a ride left it on another floor (the cab it was made in looks
  // the same on every floor).
  if (nodes_[static_cast<size_t>(active_)].floor == floors_.floor()) return active_;
  return std::nullopt;
}

void Mapper::finishStep(bool registered) {
  const InFlight f = *in_flight_;
  in_flight_.reset();
  if (registered) recovery_.confirmed(f.keyframe_utime, bridges(), tracker_.odometerM());
  if (registered) map_confirmed_ = true;
  const bool gate_rejected = std::exchange(gate_rejected_, false);
  const auto t0 = SteadyClock::now();
  const double c0 = threadCpuSeconds();
  if (lost_) {
    // Not re-localised yet: neither a node nor a step pose from a meaningless Δ.
    stats_.timing.partition_s += secondsSince(t0);
    stats_.timing.step_cost.push_back(
        {f.keyframe_utime, step_cost_s_ + secondsSince(t0), step_cpu_s_ + threadCpuSeconds() - c0});
    return;
  }
  // A registration the gate rejected still says a node is near (or it is a false match, and
  // the next step adds the node): no new node at this step.
  // A warm restart's unconfirmed pose places a node only while it is known to a cell or so.
  const double sigma_m = std::sqrt(
      std::max(f.delta_at_keyframe.covariance(0, 0), f.delta_at_keyframe.covariance(1, 1)));
  const bool placeable = !warm_.unconfirmed() || sigma_m <= o_.warm_restart_node_sigma_m;
  if (!registered && !gate_rejected && !o_.full_graph && placeable) {
    const core::SE3d world_T_body = nodePose(f.active) * f.delta_at_keyframe.mean;
    if (!nodeAt(world_T_body, floors_.floor(), f.keyframe_utime)) {
      // A new place (eq. 8): the node at the keyframe, and Δ restarts from it.
      addNode(f.keyframe_utime, f.delta_at_keyframe);
      tracker_.reset(tracker_.sinceKeyframe(f.keyframe_utime).value_or(core::UncertainPose{}));
      relocalize_ = false;
    }
  }
  if (registered && f.view && o_.footprints && !o_.full_graph)
    addFootprint(*f.view, f.keyframe_utime);
  stats_.timing.partition_s += secondsSince(t0);
  flushSolver();
  const auto q_T_now = tracker_.sinceKeyframe(f.keyframe_utime);
  const core::SE3d node_T_q =
      tracker_.delta().mean * (q_T_now ? q_T_now->mean.inverse() : core::SE3d());
  // A warm restart's unconfirmed pose is the held one, metres off: no step pose (as no POSE).
  if (!warm_.unconfirmed())
    step_poses_.push_back(StepPose{f.keyframe_utime, active_, node_T_q, session_});
  stats_.timing.step_cost.push_back(
      {f.keyframe_utime, step_cost_s_ + secondsSince(t0), step_cpu_s_ + threadCpuSeconds() - c0});
}

}  // namespace evermap::mapper
