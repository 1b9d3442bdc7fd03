#include "mapper-proc/mapper.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <set>
#include <sstream>
#include <utility>

#include <Eigen/Cholesky>

#include "core/common/clocks.h"
#include "core/solver/pose_factors.h"
#include "mapper-proc/map_store.h"

namespace evermap::mapper {

void MapperStats::addCounters(const MapperStats& o) {
  steps += o.steps;
  nodes += o.nodes;
  constraints += o.constraints;
  factors += o.factors;
  merged += o.merged;
  rejected_inconsistent += o.rejected_inconsistent;
  requests_node += o.requests_node;
  requests_global += o.requests_global;
  registrations_ok += o.registrations_ok;
  loop_closures += o.loop_closures;
  delta_replaced += o.delta_replaced;
  delta_kept += o.delta_kept;
  delta_fused += o.delta_fused;
  rejected_map_gate += o.rejected_map_gate;
  rejected_floor += o.rejected_floor;
  closures_saturated += o.closures_saturated;
  gate_recoveries += o.gate_recoveries;
  recoveries_too_far += o.recoveries_too_far;
  relocalizations += o.relocalizations;
  relocalization_disagreements += o.relocalization_disagreements;
  relocalization_same_frame_checks += o.relocalization_same_frame_checks;
  implausible_floors += o.implausible_floors;
  timeouts += o.timeouts;
  dropped += o.dropped;
  restored_nodes += o.restored_nodes;
  restored_constraints += o.restored_constraints;
  warm_restarts += o.warm_restarts;
  lost_restarts += o.lost_restarts;
  warm_confirmations += o.warm_confirmations;
  warm_rejections += o.warm_rejections;
  warm_bridged += o.warm_bridged;
  warm_bridged_by_wheels += o.warm_bridged_by_wheels;
  warm_wheel_waits += o.warm_wheel_waits;
  warm_elevator_refusals += o.warm_elevator_refusals;
}

std::string MapperStats::text() const {
  std::ostringstream s;
  s << "steps " << steps << "\nnodes " << nodes << "\nconstraints " << constraints << "\nfactors "
    << factors << "\nmerged " << merged << "\nrejected_inconsistent " << rejected_inconsistent
    << "\nrequests_node " << requests_node << "\nrequests_global " << requests_global
    << "\nregistrations_ok " << registrations_ok << "\nloop_closures " << loop_closures
    << "\ndelta_replaced " << delta_replaced << "\ndelta_kept " << delta_kept << "\ndelta_fused "
    << delta_fused << "\nrejected_map_gate " << rejected_map_gate << "\nrejected_floor "
    << rejected_floor << "\nclosures_saturated " << closures_saturated << "\ngate_recoveries "
    << gate_recoveries << "\nrecoveries_too_far " << recoveries_too_far << "\nrelocalizations "
    << relocalizations << "\ntimeouts " << timeouts << "\ndropped " << dropped
    << "\nrelocalization_disagreements " << relocalization_disagreements
    << "\nrelocalization_same_frame_checks " << relocalization_same_frame_checks
    << "\nrestored_nodes " << restored_nodes << "\nimplausible_floors " << implausible_floors
    << "\nrestored_constraints " << restored_constraints << "\nwarm_restarts " << warm_restarts
    << "\nlost_restarts " << lost_restarts << "\nwarm_confirmations " << warm_confirmations
    << "\nwarm_rejections " << warm_rejections << "\nwarm_bridged " << warm_bridged
    << "\nwarm_bridged_by_wheels " << warm_bridged_by_wheels << "\nwarm_wheel_waits "
    << warm_wheel_waits << "\nwarm_elevator_refusals " << warm_elevator_refusals << "\n";
  return s.str();
}

Mapper::Mapper(const MapperOptions& options, int session)
    : o_(options),
      session_(session),
      first_session_(session),
      partition_({options.cell_size_m, options.heading_bins, options.overlap_radius_cells,
                  options.overlap_heading_sectors, options.cell_refresh_per_step}),
      tracker_(options.tracker),
      constraints_(options.consistency_gate),
      schedule_(options.solver, options.defer_merges, options.covariance_floor) {}

Status Mapper::onVo(const vo_delta_t& msg) {
  // A keyframe step the tracker held for its heading is taken before VO moves on; after a
  // session's gap, without the mapper's step (it would belong to the session before).
  const bool session_gap =
      last_vo_utime_ >= 0 && msg.utime - last_vo_utime_ > micros(o_.session_gap_s);
  takeHeldStep(msg.utime, session_gap);
  if (saved_tracking_ && waitForWheels(msg)) {
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
  if (saved_tracking_) decideRestart(msg);
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
  if (tracker_.referenceUtime() == keyframe_utime && !in_flight_ && !in_elevator_ &&
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
  if (!have_floor_ || active_ < 0) return;  // nothing mapped yet: the first session goes on
  // The FLOOR message and the VO gap both announce a session: one session per gap.
  if (lost_ && session_start_utime_ >= 0 &&
      std::abs(utime - session_start_utime_) < micros(o_.session_gap_s))
    return;
  // Where the robot is relative to the map is unknown until a global registration
  // re-localises it (DESIGN.md section 3).
  lost_ = true;
  relocalization_candidate_.reset();
  rejected_candidate_.reset();
  ++session_;
  session_start_utime_ = utime;
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
  // A ride's start stops the steps after it, not one held before it; a session's start
  // (EVENT_NONE) ends the session the held step belongs to: no mapper step then.
  takeHeldStep(msg.utime, msg.event == floor_t::EVENT_NONE);
  if (!std::isfinite(msg.height_m) || !std::isfinite(msg.height_sigma_m) ||
      msg.height_sigma_m < 0 || msg.utime < last_floor_utime_) {
    ++stats_.dropped;
    return makeError("FLOOR ", msg.utime, ": not finite or out of order");
  }
  if (const std::string implausible = floor_gate_.check(msg); !implausible.empty()) {
    ++stats_.dropped;
    ++stats_.implausible_floors;
    return makeError("FLOOR ", msg.utime, ": ", implausible);
  }
  floor_gate_.accept(msg);
  last_floor_utime_ = msg.utime;
  // A ride or a session announced after the saved tracking state: the state's floor or
  // session is no longer the robot's (older FLOOR messages, a log replayed from its start,
  // are what the state already holds).
  if (saved_tracking_ && msg.utime > saved_tracking_->utime) {
    saved_tracking_.reset();
    ++stats_.lost_restarts;
    restart_gap_s_ = -1.0;
    restart_note_ = msg.event == floor_t::EVENT_RIDE_START || msg.event == floor_t::EVENT_RIDE_END
                        ? "a ride announced after the saved tracking state"
                        : "a session announced after the saved tracking state";
  }
  floor_confirmed_ = true;
  if (msg.event == floor_t::EVENT_RIDE_START) {
    // The floor left, at the height the ride starts from: elevator-proc announces no floor
    // before the first ride, so this is where the start floor enters the table.
    if (floor_ >= 0) {
      floor_height_m_ = floors_.emplace(floor_, msg.height_m).first->second;
      have_floor_ = true;  // so the ride's end moves the estimate to the new floor's height
    }
    // The cab is a place that moves: no step (no node, no registration) until the ride ends.
    in_elevator_ = true;
    return Ok{};
  }
  in_elevator_ = false;
  if (msg.event == floor_t::EVENT_NONE) startSession(msg.utime);
  if (msg.event == floor_t::EVENT_RIDE_END) ++rides_;
  if (have_floor_ && msg.event == floor_t::EVENT_RIDE_END && active_ >= 0) {
    // The ride's vertical displacement, as far as odometry has not seen it already (VO may
    // track through the cab; wheels never do): the estimate is moved to the measured height.
    tracker_.addHeight(msg.height_m - pose().mean.translation().z(),
                       std::max(msg.height_sigma_m, 0.01));
  }
  // elevator-proc numbers floors from where it started (a restarted one, a new session,
  // calls a floor the map already has "new"): the label comes from the map's table by height.
  floor_ = msg.event == floor_t::EVENT_RIDE_END ? floorAtHeight(msg.floor_index, msg.height_m)
                                                : msg.floor_index;
  floor_height_m_ = msg.height_m;
  if (floor_ >= 0) {
    // A floor has one height: the first one reported for it, as restore() reads it back. Each
    // ride's own height estimate differs from it by that ride's error (0.1 m and more after
    // a long ride); height factors at the ride's estimate would hold the nodes of one floor at
    // heights that contradict each other and the loop closures between them, and the solver
    // would bend the poses (and with them x, y) to meet them all.
    floor_height_m_ = floors_.emplace(floor_, msg.height_m).first->second;
  }
  have_floor_ = true;
  return Ok{};
}

int Mapper::floorAtHeight(int reported, double height_m) const {
  int best = -1;
  double best_d = o_.floor_match_m;
  for (const auto& [label, h] : floors_) {
    if (std::abs(h - height_m) <= best_d) {
      best = label;
      best_d = std::abs(h - height_m);
    }
  }
  if (best >= 0) return best;
  if (reported < 0 || !floors_.contains(reported)) return reported;
  return floors_.rbegin()->first + 1;
}

std::vector<register_request_t> Mapper::takeRequests() { return std::exchange(requests_, {}); }
std::vector<node_added_t> Mapper::takeNodesAdded() { return std::exchange(nodes_added_, {}); }

core::SE3d Mapper::nodePose(int64_t id) const { return schedule_.pose(id); }

core::UncertainPose Mapper::pose() const {
  core::UncertainPose p = tracker_.delta();
  if (active_ >= 0) p.mean = nodePose(active_) * p.mean;
  return p;
}

std::optional<int64_t> Mapper::nodeAt(const core::SE3d& world_T_body, int floor,
                                      int64_t newest_allowed) const {
  return partition_.nodeAt(world_T_body, floor, newest_allowed, nodes_, schedule_.solver());
}

void Mapper::step(int64_t keyframe_utime) {
  const auto t0 = SteadyClock::now();
  const double c0 = threadCpuSeconds();
  ++stats_.steps;
  last_step_utime_ = keyframe_utime;
  step_cost_s_ = 0.0;
  step_cpu_s_ = 0.0;
  if (nodes_.empty()) {
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
  const core::SE3d world_T_body = nodePose(active_) * f.delta_at_keyframe.mean;
  std::optional<int64_t> target;
  if (lost_) {
    target = relocalizationCheck(keyframe_utime);
  } else if (resumed_ && (target = relocalizationCheck(keyframe_utime))) {
    // A warm restart's candidate placement, checked where it predicts the robot is.
  } else if (o_.full_graph) {
    target = partition_.nodeInCell(partition_.cellOf(world_T_body, floor_),
                                   keyframe_utime - micros(o_.recent_exclusion_s), nodes_);
  } else {
    target = nodeAt(world_T_body, floor_, keyframe_utime);
    // The active node, unless a ride left it on another floor (the cab it was made in looks
    // the same on every floor).
    if (!target && nodes_[static_cast<size_t>(active_)].floor == floor_) target = active_;
  }
  if (target)
    sendRequest(register_request_t::MODE_NODE, *target);
  else
    sendRequest(register_request_t::MODE_GLOBAL, -1);
  step_cost_s_ += secondsSince(t0);
  step_cpu_s_ += threadCpuSeconds() - c0;
}

void Mapper::finishStep(bool registered) {
  const InFlight f = *in_flight_;
  in_flight_.reset();
  if (registered) {
    last_confirmed_utime_ = f.keyframe_utime;
    bridges_at_confirmation_ = bridges();
    odometer_at_confirmation_ = tracker_.odometerM();
  }
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
  const bool placeable = !resumed_ || sigma_m <= o_.warm_restart_node_sigma_m;
  if (!registered && !gate_rejected && !o_.full_graph && placeable) {
    const core::SE3d world_T_body = nodePose(f.active) * f.delta_at_keyframe.mean;
    if (!nodeAt(world_T_body, floor_, f.keyframe_utime)) {
      // A new place (eq. 8): the node at the keyframe, and Δ restarts from it.
      addNode(f.keyframe_utime, f.delta_at_keyframe);
      tracker_.reset(tracker_.sinceKeyframe(f.keyframe_utime).value_or(core::UncertainPose{}));
      relocalize_ = false;
    }
  }
  stats_.timing.partition_s += secondsSince(t0);
  flushSolver();
  const auto q_T_now = tracker_.sinceKeyframe(f.keyframe_utime);
  const core::SE3d node_T_q =
      tracker_.delta().mean * (q_T_now ? q_T_now->mean.inverse() : core::SE3d());
  // A warm restart's unconfirmed pose is the held one, metres off: no step pose (as no POSE).
  if (!resumed_) step_poses_.push_back(StepPose{f.keyframe_utime, active_, node_T_q, session_});
  stats_.timing.step_cost.push_back(
      {f.keyframe_utime, step_cost_s_ + secondsSince(t0), step_cpu_s_ + threadCpuSeconds() - c0});
}

int64_t Mapper::addNode(int64_t keyframe_utime, const core::UncertainPose& active_T_node) {
  const int64_t id = static_cast<int64_t>(nodes_.size());
  core::SE3d world_T_node = active_T_node.mean;
  if (active_ >= 0) {
    world_T_node = nodePose(active_) * active_T_node.mean;
  } else {
    // The first pose defines the origin (section III-B), at the floor's height.
    world_T_node = core::SE3d(core::SO3d(), core::Vec3(0, 0, floor_height_m_));
  }
  schedule_.addVariable(id, world_T_node);
  if (active_ < 0) {
    Eigen::MatrixXd W = Eigen::MatrixXd::Zero(6, 6);
    W.diagonal() << core::Vec3::Constant(1.0 / o_.origin_sigma_m),
        core::Vec3::Constant(1.0 / o_.origin_sigma_rad);
    schedule_.addFactor(std::make_shared<solver::PosePrior3Factor>(id, world_T_node, W));
  } else {
    addConstraint(active_, id, active_T_node, ConstraintKind::kOdometry, keyframe_utime);
  }
  if (o_.height_factors && have_floor_) {
    schedule_.addFactor(std::make_shared<solver::HeightFactor>(id, floor_height_m_, 0.02));
  }
  MapperNode node{id, keyframe_utime, floor_, session_, std::nullopt};
  if (o_.attitude_factors && attitude_ && keyframe_utime - attitude_->utime <= micros(1.0)) {
    NodeAttitude a;
    a.roll_rad = attitude_->roll_rad;
    a.pitch_rad = attitude_->pitch_rad;
    a.covariance << attitude_->covariance[0], attitude_->covariance[1], attitude_->covariance[2],
        attitude_->covariance[3];
    if (addAttitudeFactor(id, a)) node.attitude = a;
  }
  nodes_.push_back(node);
  node_added_t msg{};
  msg.utime = keyframe_utime;
  msg.node_id = id;
  msg.keyframe_utime = keyframe_utime;
  msg.floor = floor_;
  msg.session = session_;
  nodes_added_.push_back(msg);
  active_ = id;
  ++stats_.nodes;
  return id;
}

bool Mapper::addAttitudeFactor(int64_t id, const NodeAttitude& a) {
  const Eigen::Matrix2d info = a.covariance.inverse();
  Eigen::LLT<Eigen::Matrix2d> llt(0.5 * (info + info.transpose()));
  if (!a.covariance.allFinite() || llt.info() != Eigen::Success) return false;
  schedule_.addFactor(std::make_shared<solver::RollPitchFactor>(id, a.roll_rad, a.pitch_rad,
                                                                Eigen::MatrixXd(llt.matrixU())));
  return true;
}

void Mapper::addConstraint(int64_t from, int64_t to, const core::UncertainPose& from_T_to,
                           ConstraintKind kind, int64_t utime, bool vetted) {
  Constraint c;
  c.from = from;
  c.to = to;
  c.from_T_to = from_T_to;
  c.kind = kind;
  c.utime = utime;
  const ConstraintSet::Pair* pair = nullptr;
  core::UncertainPose paired;
  const auto outcome = constraints_.add(c, &pair, nullptr, &paired);
  ++stats_.constraints;
  if (outcome == ConstraintSet::Outcome::kRejected) {
    ++stats_.rejected_inconsistent;
    return;
  }
  const auto key = std::make_pair(pair->i, pair->j);
  // An agreeing constraint joins its pair as a factor of its own: the product of the pair's
  // Gaussians is the information-weighted merge, and adding it is an incremental update.
  // Replacing the pair's factor by the merged one needs a factor removal, i.e. a batch step
  // whose cost grows with the map; that consolidation waits for the solver's scheduled batch
  // steps (solver_schedule.h), so merges cost what any new constraint costs.
  // i_T_j, as the pair sees it.
  const core::UncertainPose& measurement =
      outcome == ConstraintSet::Outcome::kMerged ? paired : pair->i_T_j;
  if (outcome == ConstraintSet::Outcome::kMerged) {
    ++stats_.merged;
    if (schedule_.deferMerge(key)) return;  // the pair's factor waits for its consolidation
  }
  auto factor = pairFactor(pair->i, pair->j, measurement, o_.covariance_floor);
  // A loop closure that opens its pair can be a false match that no other measurement of the
  // pair contradicts yet. The map gate tests it against the map's estimate with the map's
  // marginal covariance; one it did not test gets a robust kernel, so that the rest of the
  // graph can outvote it. Not on the others: DCS judges a factor by its residual against the
  // factor's own covariance, and when a true closure ends a long loop (an excursion to
  // another floor, a session's drift) that residual is many σ before the loop is closed,
  // although the gate, which knows the drift, found it consistent. The kernel then scales
  // the closure down to a few percent and the loop stays open: 0.20 m against 0.13 m ATE at
  // paper scale, sessions 0-3. A constraint that agreed with its pair's earlier ones
  // (χ² test above), and the pair's merged factor (consolidatePairs), have consensus.
  const solver::RobustKernel& kernel = vetted ? o_.vetted_loop_kernel : o_.loop_kernel;
  if (kind == ConstraintKind::kLoop && outcome == ConstraintSet::Outcome::kNewPair &&
      kernel.active())
    factor->setKernel(kernel);
  schedule_.addPairFactor(key, factor);
}

void Mapper::flushSolver() {
  const auto t_refresh = SteadyClock::now();
  if (partition_.refresh(nodes_, schedule_.solver()))
    stats_.timing.partition_s += secondsSince(t_refresh);
  const std::optional<SolverSchedule::Flush> flush =
      schedule_.flush(last_step_utime_, constraints_);
  if (flush) recordFlush(*flush);
}

void Mapper::recordFlush(const SolverSchedule::Flush& flush) {
  if (flush.batch_swapped) {
    step_cost_s_ += flush.wait_in_operation_s - flush.batch_wait_s;
    step_cpu_s_ += flush.wait_in_operation_s;  // a blocked thread uses no CPU
    ++stats_.timing.background_batches;
    stats_.timing.background_batch_s += flush.batch_compute_s;
    stats_.timing.background_wait_s += flush.batch_wait_s;
  }
  stats_.timing.solver_s += flush.solver_s;
  stats_.timing.update_s.push_back(flush.solver_s);
  stats_.timing.update_utime.push_back(last_step_utime_);
  stats_.factors = schedule_.factors();
  // The partition index follows the estimate after batch steps; in between only new nodes
  // join the index (partition_index.h). A synchronous batch step (the first update, a
  // restored map, a removal outside the schedule) re-files every node at once; after a
  // background batch the old nodes are re-filed over the next steps.
  const auto t1 = SteadyClock::now();
  for (int64_t id : flush.added)
    partition_.file(id, partition_.cellOf(nodePose(id), nodes_[id].floor));
  if (flush.batch) partition_.rebuild(nodes_, schedule_.solver().estimate());
  if (flush.batch_swapped) partition_.startRefresh();
  stats_.timing.partition_s += secondsSince(t1);
}

Status Mapper::restore(const MapSnapshot& map) {
  if (!nodes_.empty() || have_floor_)
    return Error{"mapper: restore: the mapper already holds a map"};
  // A map that fails half-way leaves the mapper as it was: empty.
  const auto abandon = [this](Error why) -> Status {
    nodes_.clear();
    schedule_.discard();
    constraints_ = ConstraintSet(o_.consistency_gate);
    stats_ = MapperStats{};
    return why;
  };
  std::map<int, double> floors(map.floors.begin(), map.floors.end());
  int max_session = -1;
  for (const auto& [session, start] : map.sessions) max_session = std::max(max_session, session);
  // Mappers are named in map_saved by their first session; a warm-restarted one continues an
  // older session and adds none, so the next name is past the names as well.
  max_session = std::max(max_session, map.max_saved_mapper);
  for (size_t k = 0; k < map.nodes.size(); ++k) {
    const StoredNode& n = map.nodes[k];
    if (n.node.id != static_cast<int64_t>(k))
      return abandon(
          makeError("mapper: restore: node ", n.node.id, " where node ", k, " was expected"));
    max_session = std::max(max_session, n.node.session);
    schedule_.addVariable(n.node.id, n.world_T_body);
    if (k == 0) {
      // The origin stays where the first session put it.
      Eigen::MatrixXd W = Eigen::MatrixXd::Zero(6, 6);
      W.diagonal() << core::Vec3::Constant(1.0 / o_.origin_sigma_m),
          core::Vec3::Constant(1.0 / o_.origin_sigma_rad);
      schedule_.addFactor(std::make_shared<solver::PosePrior3Factor>(0, n.world_T_body, W));
    }
    const auto height = floors.find(n.node.floor);
    if (o_.height_factors && height != floors.end()) {
      schedule_.addFactor(std::make_shared<solver::HeightFactor>(n.node.id, height->second, 0.02));
    }
    MapperNode node = n.node;
    if (node.attitude && !(o_.attitude_factors && addAttitudeFactor(node.id, *node.attitude)))
      node.attitude.reset();
    nodes_.push_back(node);
  }
  const auto n_nodes = static_cast<int64_t>(nodes_.size());
  for (size_t k = 0; k < map.edges.size(); ++k) {
    const Constraint& c = map.edges[k].constraint;
    // In the order they were made (a fold comes before its pair's later constraints).
    if ((k > 0 && map.edges[k].edge_id <= map.edges[k - 1].edge_id) || c.from < 0 || c.to < 0 ||
        c.from >= n_nodes || c.to >= n_nodes || c.from == c.to) {
      return abandon(makeError("mapper: restore: edge ", map.edges[k].edge_id, " (", c.from, " -> ",
                               c.to, ") is out of order or names an unknown node"));
    }
    // As the live mapper added it: closures of the reduced graph passed the map gate.
    addConstraint(c.from, c.to, c.from_T_to, c.kind, c.utime, o_.map_gate > 0 && !o_.full_graph);
  }
  if (nodes_.empty()) return Ok{};
  floors_ = floors;
  flushSolver();
  const int64_t factors = stats_.factors;
  stats_ = MapperStats{};
  stats_.factors = factors;
  stats_.restored_nodes = n_nodes;
  stats_.restored_constraints = static_cast<int64_t>(map.edges.size());
  session_ = max_session + 1;
  first_session_ = session_;
  active_ = n_nodes - 1;
  lost_ = true;  // where the robot is on this map is unknown until a global registration
  // ... and so is its floor, unless a FLOOR message says it (a session's start, a ride's
  // end): a mapper-proc restarted mid-session gets none. The guess is the floor of the newest
  // node (where the robot was when the map was saved); every other global search covers
  // every floor, and the relocalisation's node confirms it (sendRequest).
  int64_t newest = 0;
  for (const MapperNode& n : nodes_)
    if (n.keyframe_utime >= nodes_[static_cast<size_t>(newest)].keyframe_utime) newest = n.id;
  floor_ = nodes_[static_cast<size_t>(newest)].floor;
  floor_confirmed_ = false;
  resume_first_new_node_ = n_nodes;
  // A saved tracking state is usable only when it names a stored node and is not older than
  // the newest one (the state is written in every transaction that writes nodes, so an
  // older one is not this map's last state).
  saved_tracking_.reset();
  if (map.tracking && map.tracking->active_node >= 0 && map.tracking->active_node < n_nodes &&
      map.tracking->utime >= nodes_[static_cast<size_t>(newest)].keyframe_utime) {
    saved_tracking_ = map.tracking;
    restart_first_vo_utime_ = -1;
  } else {
    ++stats_.lost_restarts;
    restart_gap_s_ = -1.0;
    restart_note_ = !map.tracking
                        ? "no tracking state stored (the mapper was lost, or an older store)"
                        : "the stored tracking state is older than the newest node or names none";
  }
  return Ok{};
}

namespace {

// No bridge, and `why` (the parts streamed) says why not.
template <typename... Parts>
std::optional<core::UncertainPose> noBridge(std::string& why, const Parts&... parts) {
  std::ostringstream w;
  (w << ... << parts);
  why = w.str();
  return std::nullopt;
}

}  // namespace

std::optional<core::UncertainPose> Mapper::odometryBridge(const TrackingState& s,
                                                          const vo_delta_t& msg,
                                                          std::string& why) const {
  if (!o_.warm_restart_bridge) return noBridge(why, "mapper.warm_restart_bridge is off");
  if (!s.odometry) return noBridge(why, "the saved state holds no odometry pose");
  std::string malformed;
  const auto now = messages::odometryPose(msg, &malformed);
  if (!now) return noBridge(why, "the first VO_DELTA: ", malformed);
  const messages::OdometryPose& saved = s.odometry->pose;
  if (now->epoch != saved.epoch)
    return noBridge(why, "odometry epoch ", saved.epoch, " then, ", now->epoch, " now");
  const double gap_s = 1e-6 * static_cast<double>(now->utime - saved.utime);
  if (gap_s > o_.warm_restart_bridge_max_gap_s)
    return noBridge(why, gap_s, " s > mapper.warm_restart_bridge_max_gap_s");
  const auto cam = messages::odometryBetween(saved, s.odometry->own_covariance, *now);
  if (!cam) return noBridge(why, cam.error().message);
  // saved_T_now of the body; the odometry's frame is the camera's.
  const core::UncertainPose body = tracker_.toBody(cam->mean, cam->covariance);
  if (const std::string implausible =
          tracker_.implausibleMotion(body.mean.translation().norm(),
                                     core::rotationAngle(body.mean.so3()), saved.utime, now->utime);
      !implausible.empty())
    return noBridge(why, "implausible: ", implausible);
  // The body is level (to the IMU's accuracy): its z is the world's vertical.
  if (std::abs(body.mean.translation().z()) > o_.floor_match_m)
    return noBridge(why, "a vertical motion of ", body.mean.translation().z(), " m (a ride?)");
  return body;
}

std::optional<core::UncertainPose> Mapper::wheelBridge(const TrackingState& s, int64_t utime,
                                                       std::string& why) const {
  if (!o_.warm_restart_bridge) return noBridge(why, "mapper.warm_restart_bridge is off");
  if (!s.wheel) return noBridge(why, "the saved state holds no wheel odometry pose");
  const auto now = tracker_.wheelOdometryAt(utime);
  if (!now) return noBridge(why, "no wheel odometry pose at ", utime);
  if (now->epoch != s.wheel->epoch)
    return noBridge(why, "wheel odometry epoch ", s.wheel->epoch, " then, ", now->epoch, " now");
  const double gap_s = 1e-6 * static_cast<double>(now->utime - s.wheel->utime);
  if (gap_s > o_.warm_restart_bridge_max_gap_s)
    return noBridge(why, gap_s, " s > mapper.warm_restart_bridge_max_gap_s");
  const auto d = messages::wheelOdometryBetween(*s.wheel, *now);
  if (!d) return noBridge(why, d.error().message);
  // The SSC covariance is over (x, y) in the start frame; the right tangent's translation is
  // in the end frame: rotated by the motion's θ.
  Eigen::Matrix3d to_right = Eigen::Matrix3d::Identity();
  to_right.topLeftCorner<2, 2>() = d->a_T_b.rotationMatrix().transpose();
  const core::UncertainPose body =
      tracker_.planarMotion(d->a_T_b.vector(), to_right * d->covariance * to_right.transpose());
  const double distance_m = d->a_T_b.translation().norm();
  const double angle_rad = std::abs(d->a_T_b.theta());
  if (const std::string implausible =
          tracker_.implausibleMotion(distance_m, angle_rad, s.wheel->utime, now->utime);
      !implausible.empty())
    return noBridge(why, "implausible: ", implausible);
  return body;
}

std::optional<std::pair<int64_t, double>> Mapper::elevatorNear(
    const core::SE3d& world_T_body) const {
  std::optional<std::pair<int64_t, double>> best;
  if (o_.warm_restart_elevator_radius_m <= 0.0) return best;
  const auto n = static_cast<int64_t>(nodes_.size());
  for (const Constraint& c : constraints_.all()) {
    if (c.kind != ConstraintKind::kOdometry || c.from < 0 || c.to < 0 || c.from >= n || c.to >= n)
      continue;
    if (nodes_[static_cast<size_t>(c.from)].floor == nodes_[static_cast<size_t>(c.to)].floor)
      continue;
    for (const int64_t id : {c.from, c.to}) {
      const double d = (nodePose(id).translation() - world_T_body.translation()).head<2>().norm();
      if (d <= o_.warm_restart_elevator_radius_m && (!best || d < best->second))
        best = std::pair{id, d};
    }
  }
  return best;
}

bool Mapper::waitForWheels(const vo_delta_t& msg) {
  if (o_.warm_restart_wheel_wait_s <= 0.0 || !saved_tracking_->wheel ||
      saved_tracking_->in_elevator || tracker_.wheelOdometryAt(msg.utime))
    return false;
  // A gap no bridge crosses (a new session's first frame, hours or days after the state):
  // nothing to wait for, and the frames set aside would be the session's first keyframe,
  // where the robot stands where it stood before (the relocalisation's best chance).
  if (1e-6 * static_cast<double>(msg.utime - saved_tracking_->utime) >
      o_.warm_restart_bridge_max_gap_s)
    return false;
  if (restart_first_vo_utime_ < 0) restart_first_vo_utime_ = msg.utime;
  if (msg.utime - restart_first_vo_utime_ > micros(o_.warm_restart_wheel_wait_s)) return false;
  std::string why_not;
  return !odometryBridge(*saved_tracking_, msg, why_not);
}

void Mapper::decideRestart(const vo_delta_t& msg) {
  const int64_t utime = msg.utime;
  const TrackingState s = *saved_tracking_;
  saved_tracking_.reset();
  const double gap_s = 1e-6 * static_cast<double>(utime - s.utime);
  restart_gap_s_ = gap_s;
  if (s.in_elevator || !(gap_s >= 0.0) || o_.full_graph || o_.warm_restart_max_gap_s <= 0.0) {
    restart_note_ = s.in_elevator ? "saved in the elevator cab"
                                  : "no warm restart (options, or a state from the future)";
    ++stats_.lost_restarts;
    return;
  }
  // Where the robot was at s.utime, in its session, on its floor. With the odometry frame
  // the motion over the gap is known (a measurement, as Δ's own increments): tracking goes on.
  // Without it nothing tracked it for gap_s: the covariance grows by what it may have driven
  // and turned meanwhile (linear in the gap: a bounded speed); height, roll and pitch stay
  // (a floor, a level body).
  std::string vo_why, wheel_why;
  std::optional<core::UncertainPose> bridge = odometryBridge(s, msg, vo_why);
  bool by_wheels = false;
  if (!bridge) {
    bridge = wheelBridge(s, utime, wheel_why);
    by_wheels = bridge.has_value();
  }
  std::ostringstream note;
  if (!bridge) {
    note << "not bridged: " << vo_why << "; wheels: " << wheel_why;
  } else {
    const int64_t from_utime = by_wheels ? s.wheel->utime : s.odometry->pose.utime;
    note << (by_wheels ? "bridged by wheel odometry over " : "bridged by odometry over ")
         << 1e-6 * static_cast<double>(utime - from_utime)
         << " s: " << bridge->mean.translation().norm() << " m, "
         << core::rotationAngle(bridge->mean.so3()) << " rad";
    if (by_wheels) note << " (VO not bridged: " << vo_why << ")";
  }
  restart_note_ = note.str();
  // Near an elevator, a gap long enough to ride may hold a ride neither bridge sees: the
  // floor is unknown, so the restart is lost (global searches on every floor), not inflated.
  if (gap_s >= o_.warm_restart_ride_min_s && s.active_node >= 0 &&
      s.active_node < static_cast<int64_t>(nodes_.size())) {
    const core::SE3d saved = nodePose(s.active_node) * s.active_T_body.mean;
    auto near = elevatorNear(saved);
    if (!near && bridge) near = elevatorNear(saved * bridge->mean);
    if (near) {
      std::ostringstream elevator;
      elevator << near->second << " m from the elevator at node " << near->first << " over "
               << gap_s << " s: a ride may lie in the gap ("
               << (bridge ? "not bridged" : restart_note_) << ")";
      restart_note_ = elevator.str();
      ++stats_.lost_restarts;
      ++stats_.warm_elevator_refusals;
      return;
    }
  }
  if (!bridge && gap_s > o_.warm_restart_max_gap_s) {
    ++stats_.lost_restarts;
    return;
  }
  core::UncertainPose delta = s.active_T_body;
  if (bridge) {
    delta = core::compound(delta, *bridge);
  } else {
    const double sigma_m = o_.warm_restart_speed_m_s * gap_s;
    const double sigma_rad = std::min(o_.warm_restart_turn_rad_s * gap_s, std::numbers::pi);
    core::Vec6 grow;
    grow << sigma_m * sigma_m, sigma_m * sigma_m, 0.0025 * gap_s, 1e-4 * gap_s, 1e-4 * gap_s,
        sigma_rad * sigma_rad;
    delta.covariance += grow.asDiagonal();
  }
  active_ = s.active_node;
  session_ = s.session;
  session_start_utime_ = s.session_start_utime;
  floor_ = s.floor;
  floor_confirmed_ = true;
  const auto height = floors_.find(floor_);
  if (height != floors_.end()) {
    floor_height_m_ = height->second;
    have_floor_ = true;
  }
  // The first VO frame after the restart is placed where this estimate has the body (its
  // reference is unknown to the new tracker: reanchored), so no motion is applied twice.
  tracker_.reset(delta);
  lost_ = false;
  // A bridged pose needs no confirmation: the odometry between the two frames is the chain of
  // VO motions the tracker would have compounded into Δ had it received them, with their
  // covariance, so registrations are tested against it by the map gate as against any Δ.
  // The held pose is off by what the robot drove in the gap: confirmed before any closure.
  resumed_ = !bridge;
  relocalize_ = false;
  relocalization_candidate_.reset();
  rejected_candidate_.reset();
  ++stats_.warm_restarts;
  if (bridge) ++stats_.warm_bridged;
  if (by_wheels) ++stats_.warm_bridged_by_wheels;
}

std::optional<TrackingState> Mapper::trackingState() const {
  if (lost_ || active_ < 0 || nodes_.empty() || tracker_.lastUtime() < 0) return std::nullopt;
  TrackingState s;
  s.utime = tracker_.lastUtime();
  s.session = session_;
  s.session_start_utime = session_start_utime_;
  s.active_node = active_;
  s.floor = floor_;
  s.in_elevator = in_elevator_;
  s.active_T_body = tracker_.delta();
  s.odometry = tracker_.odometryAtDelta();
  s.wheel = tracker_.wheelOdometryAt(tracker_.deltaUtime());
  return s;
}

}  // namespace evermap::mapper
