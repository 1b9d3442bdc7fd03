#include "mapper-proc/mapper.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <limits>
#include <numbers>
#include <sstream>
#include <utility>

#include <Eigen/Cholesky>

#include "core/solver/marginals.h"
#include "core/solver/pose_factors.h"
#include "mapper-proc/map_store.h"

namespace evermap::mapper {
namespace {

using Clock = std::chrono::steady_clock;
double secondsSince(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// CPU time of the calling thread: a step's work without the time other threads and processes
// held the core (measurement only, like the wall clock above).
double threadCpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

int64_t micros(double s) { return static_cast<int64_t>(std::llround(s * 1e6)); }

Eigen::MatrixXd sqrtInformation(const core::Mat6& covariance, double floor) {
  const core::Mat6 c = covariance + floor * core::Mat6::Identity();
  // Upper-triangular W with WᵀW = Σ⁻¹: the transposed Cholesky factor of the information.
  const core::Mat6 info = c.ldlt().solve(core::Mat6::Identity());
  const core::Mat6 sym = 0.5 * (info + info.transpose());
  Eigen::LLT<core::Mat6> llt(sym);
  return Eigen::MatrixXd(llt.matrixU());
}

}  // namespace

Status MapperOptions::validate() const {
  if (!(cell_size_m > 0.0)) return Error{"mapper.cell_size_m: must be > 0"};
  if (heading_bins < 1) return Error{"mapper.heading_bins: must be >= 1"};
  if (!(overlap_radius_cells >= 0.0 && overlap_radius_cells <= 1.0))
    return Error{"mapper.overlap_radius_cells: must be in [0, 1]"};
  if (!(overlap_heading_sectors >= 0.0 && overlap_heading_sectors <= 1.0))
    return Error{"mapper.overlap_heading_sectors: must be in [0, 1]"};
  if (relocalization_checks < 0) return Error{"mapper.relocalization_checks: must be >= 0"};
  if (!(step_interval_s >= 0.0)) return Error{"mapper.step_interval_s: must be >= 0"};
  if (!(request_timeout_s > 0.0)) return Error{"mapper.request_timeout_s: must be > 0"};
  if (!(session_gap_s > 0.0)) return Error{"mapper.session_gap_s: must be > 0"};
  if (!(recovery_quiet_s >= 0.0)) return Error{"mapper.recovery_quiet_s: must be >= 0"};
  if (!(recovery_slack_m >= 0.0)) return Error{"mapper.recovery_slack_m: must be >= 0"};
  if (!(recovery_drift_fraction >= 0.0)) return Error{"mapper.recovery_drift_fraction: must be >= 0"};
  if (!(floor_match_m > 0.0)) return Error{"mapper.floor_match_m: must be > 0"};
  if (!(consistency_gate > 0.0)) return Error{"mapper.consistency_gate: must be > 0"};
  if (!(map_gate >= 0.0)) return Error{"mapper.map_gate: must be >= 0"};
  if (!(min_closure_information >= 0.0) || !std::isfinite(min_closure_information))
    return Error{"mapper.min_closure_information: must be a finite number >= 0"};
  if (!(recent_exclusion_s >= 0.0)) return Error{"mapper.recent_exclusion_s: must be >= 0"};
  if (!(covariance_floor >= 0.0)) return Error{"mapper.covariance_floor: must be >= 0"};
  if (cell_refresh_per_step < 1) return Error{"mapper.cell_refresh_per_step: must be >= 1"};
  if (!(origin_sigma_m > 0.0) || !(origin_sigma_rad > 0.0))
    return Error{"mapper.origin_sigma: must be > 0"};
  if (auto s = tracker.validate(); !s) return s;
  return solver.validate();
}

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
  closures_uninformative += o.closures_uninformative;
  gate_recoveries += o.gate_recoveries;
  recoveries_too_far += o.recoveries_too_far;
  relocalizations += o.relocalizations;
  relocalization_disagreements += o.relocalization_disagreements;
  relocalization_same_frame_checks += o.relocalization_same_frame_checks;
  timeouts += o.timeouts;
  dropped += o.dropped;
  restored_nodes += o.restored_nodes;
  restored_constraints += o.restored_constraints;
}

std::string MapperStats::text() const {
  std::ostringstream s;
  s << "steps " << steps << "\nnodes " << nodes << "\nconstraints " << constraints
    << "\nfactors " << factors << "\nmerged " << merged << "\nrejected_inconsistent "
    << rejected_inconsistent << "\nrequests_node " << requests_node << "\nrequests_global "
    << requests_global << "\nregistrations_ok " << registrations_ok << "\nloop_closures "
    << loop_closures << "\ndelta_replaced " << delta_replaced << "\ndelta_kept " << delta_kept << "\ndelta_fused " << delta_fused
    << "\nrejected_map_gate " << rejected_map_gate << "\nrejected_floor " << rejected_floor << "\nclosures_uninformative " << closures_uninformative << "\ngate_recoveries " << gate_recoveries << "\nrecoveries_too_far " << recoveries_too_far << "\nrelocalizations " << relocalizations
    << "\ntimeouts " << timeouts << "\ndropped " << dropped << "\nrelocalization_disagreements " << relocalization_disagreements << "\nrelocalization_same_frame_checks " << relocalization_same_frame_checks << "\nrestored_nodes " << restored_nodes
    << "\nrestored_constraints " << restored_constraints << "\n";
  return s.str();
}

Mapper::Mapper(const MapperOptions& options, int session)
    : o_(options),
      session_(session),
      first_session_(session),
      grid_{options.cell_size_m, options.heading_bins},
      tracker_(options.tracker),
      constraints_(options.consistency_gate),
      solver_(options.solver) {}

Status Mapper::onVo(const vo_delta_t& msg) {
  const auto t0 = Clock::now();
  const Status s = tracker_.addVo(msg);
  stats_.timing.tracking_s += secondsSince(t0);
  if (!s) {
    ++stats_.dropped;
    return s;
  }
  checkTimeout(msg.utime);
  if (last_vo_utime_ >= 0 && msg.utime - last_vo_utime_ > micros(o_.session_gap_s)) startSession(msg.utime);
  last_vo_utime_ = msg.utime;
  // A step at a keyframe the tracker now chains from (a chain break's new reference too).
  if (msg.keyframe_changed && tracker_.referenceUtime() == msg.utime && !in_flight_ && !in_elevator_ && (last_step_utime_ < 0 || msg.utime - last_step_utime_ >= micros(o_.step_interval_s)))
    step(msg.utime);
  return Ok{};
}

void Mapper::startSession(int64_t utime) {
  if (!have_floor_ || active_ < 0) return;  // nothing mapped yet: the first session goes on
  // The FLOOR message and the VO gap both announce a session: one session per gap.
  if (lost_ && session_start_utime_ >= 0 && std::abs(utime - session_start_utime_) < micros(o_.session_gap_s)) return;
  // Where the robot is relative to the map is unknown until a global registration
  // re-localises it (DESIGN.md section 3).
  lost_ = true;
  relocalization_candidate_.reset();
  rejected_candidate_.reset();
  ++session_;
  session_start_utime_ = utime;
}

Status Mapper::onWheel(const wheel_odom_t& msg) {
  const auto t0 = Clock::now();
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
      std::abs(msg.covariance[1] - msg.covariance[2]) > 1e-9 * std::max(msg.covariance[0], msg.covariance[3])) {
    ++stats_.dropped;
    return makeError("ATTITUDE ", msg.utime, ": not finite, out of order or not a covariance");
  }
  last_attitude_utime_ = msg.utime;
  if (msg.accel_trusted) attitude_ = msg;
  return tracker_.addHeading(msg);
}

Status Mapper::onFloor(const floor_t& msg) {
  if (!std::isfinite(msg.height_m) || !std::isfinite(msg.height_sigma_m) || msg.height_sigma_m < 0 ||
      msg.utime < last_floor_utime_) {
    ++stats_.dropped;
    return makeError("FLOOR ", msg.utime, ": not finite or out of order");
  }
  last_floor_utime_ = msg.utime;
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
    tracker_.addHeight(msg.height_m - pose().mean.translation().z(), std::max(msg.height_sigma_m, 0.01));
  }
  // elevator-proc numbers floors from where it started (a restarted one, a new session,
  // calls a floor the map already has "new"): the label comes from the map's table by height.
  floor_ = msg.event == floor_t::EVENT_RIDE_END ? floorAtHeight(msg.floor_index, msg.height_m) : msg.floor_index;
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

core::SE3d Mapper::nodePose(int64_t id) const { return solver_.estimate(id).se3; }

core::UncertainPose Mapper::pose() const {
  core::UncertainPose p = tracker_.delta();
  if (active_ >= 0) p.mean = nodePose(active_) * p.mean;
  return p;
}

core::PlanarCell Mapper::cellOf(const core::SE3d& world_T_body, int floor) const {
  return grid_.cellOf(core::toPlanar(world_T_body), floor);
}

std::optional<int64_t> Mapper::nodeInCell(const core::PlanarCell& cell, int64_t newest_allowed) const {
  auto it = cells_.find(cell);
  if (it == cells_.end()) return std::nullopt;
  // The most recently added node of the cell (paper section IV-B).
  for (auto id = it->second.rbegin(); id != it->second.rend(); ++id)
    if (nodes_[*id].keyframe_utime <= newest_allowed) return *id;
  return std::nullopt;
}

double Mapper::overlapHeadingRad() const {
  return o_.overlap_heading_sectors * 2.0 * std::numbers::pi / o_.heading_bins;
}

double Mapper::headingApartRad(const core::SE2d& a, const core::SE2d& b) {
  return std::abs(std::remainder(a.theta() - b.theta(), 2.0 * std::numbers::pi));
}

std::optional<int64_t> Mapper::overlappingNode(const core::SE3d& world_T_body, int floor,
                                               int64_t newest_allowed) const {
  const double radius_m = o_.overlap_radius_cells * o_.cell_size_m;
  const double heading_rad = overlapHeadingRad();
  if (!(radius_m > 0.0) || !(heading_rad > 0.0)) return std::nullopt;
  const core::SE2d p = core::toPlanar(world_T_body);
  const core::PlanarCell c = grid_.cellOf(p, floor);
  std::optional<int64_t> best;
  double best_score = 2.0;
  // The overlap is at most a cell and a sector wide: the neighbours hold every candidate.
  for (int dx = -1; dx <= 1; ++dx) {
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dh = -1; dh <= 1; ++dh) {
        if (dh != 0 && o_.heading_bins < 3 && (dh < 0 || o_.heading_bins == 1)) continue;  // each sector once
        core::PlanarCell n{floor, c.ix + dx, c.iy + dy, (c.iheading + dh + o_.heading_bins) % o_.heading_bins};
        auto it = cells_.find(n);
        if (it == cells_.end()) continue;
        for (int64_t id : it->second) {
          if (nodes_[static_cast<size_t>(id)].keyframe_utime > newest_allowed) continue;
          const core::SE2d q = core::toPlanar(nodePose(id));
          const double d = std::hypot(q.x() - p.x(), q.y() - p.y()) / radius_m;
          const double a = headingApartRad(q, p) / heading_rad;
          if (d > 1.0 || a > 1.0) continue;
          if (d + a < best_score) {
            best_score = d + a;
            best = id;
          }
        }
      }
    }
  }
  return best;
}

void Mapper::rebuildCells() {
  const auto t0 = Clock::now();
  cells_.clear();
  node_cell_.clear();
  const solver::Values est = solver_.estimate();
  for (const MapperNode& n : nodes_) fileInCell(n.id, cellOf(est[n.id].se3, n.floor));
  refresh_next_ = SIZE_MAX;
  stats_.timing.partition_s += secondsSince(t0);
}

void Mapper::fileInCell(int64_t id, const core::PlanarCell& cell) {
  const auto k = static_cast<size_t>(id);
  if (k < node_cell_.size()) {
    if (node_cell_[k] == cell) return;
    auto& old = cells_[node_cell_[k]];
    old.erase(std::find(old.begin(), old.end(), id));
    node_cell_[k] = cell;
  } else {
    node_cell_.push_back(cell);  // nodes are filed first in id order
  }
  auto& ids = cells_[cell];
  ids.insert(std::lower_bound(ids.begin(), ids.end(), id), id);
}

void Mapper::refreshCells() {
  if (refresh_next_ >= nodes_.size()) return;
  const auto t0 = Clock::now();
  const size_t end = std::min(nodes_.size(), refresh_next_ + static_cast<size_t>(o_.cell_refresh_per_step));
  for (; refresh_next_ < end; ++refresh_next_) {
    const MapperNode& n = nodes_[refresh_next_];
    fileInCell(n.id, cellOf(nodePose(n.id), n.floor));
  }
  if (refresh_next_ >= nodes_.size()) refresh_next_ = SIZE_MAX;
  stats_.timing.partition_s += secondsSince(t0);
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
  const auto outcome = constraints_.add(c, &pair);
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
  // steps (flushSolver), so merges cost what any new constraint costs.
  const Constraint& stored = constraints_.all().back();  // i_T_j, as the set keeps it
  const core::UncertainPose& measurement = outcome == ConstraintSet::Outcome::kMerged ? stored.from_T_to : pair->i_T_j;
  if (outcome == ConstraintSet::Outcome::kMerged) {
    ++stats_.merged;
    to_consolidate_.insert(key);
    // A pair the solver already holds a factor of: the merge refines it, and waits for the
    // next consolidation instead of an incremental update now (on a map that has stopped
    // growing most constraints are such refinements, and each update's cost grows with the
    // elimination path of the pair).
    if (o_.defer_merges && pair_factor_.count(key)) {
      ++deferred_merges_;
      return;
    }
  }
  auto factor = std::make_shared<solver::RelativePose3Factor>(
      pair->i, pair->j, measurement.mean, sqrtInformation(measurement.covariance, o_.covariance_floor),
      solver::RelativePose3Factor::Convention::kLog);
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
  if (kind == ConstraintKind::kLoop && outcome == ConstraintSet::Outcome::kNewPair && kernel.active())
    factor->setKernel(kernel);
  pending_pairs_.push_back(key);
  pending_factor_slot_.push_back(pending_update_.new_factors.size());
  pending_update_.new_factors.push_back(factor);
}

void Mapper::consolidatePairs() {
  // Pairs with several factors, none of them still waiting in this update: their factors
  // are replaced by the one merged constraint of the set (paper section III-B.3: redundant
  // constraints combined once they agree).
  std::set<std::pair<int64_t, int64_t>> waiting(pending_pairs_.begin(), pending_pairs_.end());
  for (auto it = to_consolidate_.begin(); it != to_consolidate_.end();) {
    auto factors = pair_factor_.find(*it);
    if (waiting.count(*it) || factors == pair_factor_.end()) {
      ++it;
      continue;
    }
    const ConstraintSet::Pair& pair = constraints_.pairs().at(*it);
    for (solver::FactorId id : factors->second) pending_update_.remove_factors.push_back(id);
    pair_factor_.erase(factors);
    auto factor = std::make_shared<solver::RelativePose3Factor>(
        pair.i, pair.j, pair.i_T_j.mean, sqrtInformation(pair.i_T_j.covariance, o_.covariance_floor),
        solver::RelativePose3Factor::Convention::kLog);
    pending_pairs_.push_back(*it);
    pending_factor_slot_.push_back(pending_update_.new_factors.size());
    pending_update_.new_factors.push_back(factor);
    it = to_consolidate_.erase(it);
  }
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
  pending_update_.new_variables.emplace_back(id, solver::PoseValue::spatial(world_T_node));
  if (active_ < 0) {
    Eigen::MatrixXd W = Eigen::MatrixXd::Zero(6, 6);
    W.diagonal() << core::Vec3::Constant(1.0 / o_.origin_sigma_m), core::Vec3::Constant(1.0 / o_.origin_sigma_rad);
    pending_update_.new_factors.push_back(std::make_shared<solver::PosePrior3Factor>(id, world_T_node, W));
    pending_pairs_.emplace_back(-1, -1);
    pending_factor_slot_.push_back(pending_update_.new_factors.size() - 1);
  } else {
    addConstraint(active_, id, active_T_node, ConstraintKind::kOdometry, keyframe_utime);
  }
  if (o_.height_factors && have_floor_) {
    pending_update_.new_factors.push_back(std::make_shared<solver::HeightFactor>(id, floor_height_m_, 0.02));
    pending_pairs_.emplace_back(-1, -1);
    pending_factor_slot_.push_back(pending_update_.new_factors.size() - 1);
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
  pending_update_.new_factors.push_back(
      std::make_shared<solver::RollPitchFactor>(id, a.roll_rad, a.pitch_rad, Eigen::MatrixXd(llt.matrixU())));
  pending_pairs_.emplace_back(-1, -1);
  pending_factor_slot_.push_back(pending_update_.new_factors.size() - 1);
  return true;
}

void Mapper::flushSolver() {
  refreshCells();
  // Merged pairs are consolidated (their factors replaced by the one merged constraint) at the
  // solver's scheduled batch steps: it batch-steps every batch_every-th update anyway (its
  // update counter starts at 0), so the removals cost nothing extra. A map that no longer
  // changes has few updates: there, batch_every deferred merges trigger the consolidation.
  const auto t0 = Clock::now();
  const int every = o_.solver.batch_every;
  const bool changes = !pending_update_.new_variables.empty() || !pending_update_.new_factors.empty();
  const bool scheduled = every > 0 && changes && solver_updates_ % every == 0;
  const bool idle = every > 0 && !changes && deferred_merges_ >= every;
  if ((scheduled || idle) && !to_consolidate_.empty()) {
    consolidatePairs();
    deferred_merges_ = 0;
  }
  if (!changes && pending_update_.remove_factors.empty()) return;
  ++solver_updates_;
  auto result = solver_.update(pending_update_);
  double dt = secondsSince(t0);
  // Contract: the mapper only builds updates over keys it created, with finite factors.
  if (!result) {
    std::fprintf(stderr, "evermap-mapper: solver update failed: %s\n", result.error().message.c_str());
    std::abort();
  }
  if (result->batch_started) batch_start_utime_ = last_step_utime_;
  if (result->batch_swapped) {
    // The worker had the message time since the start to finish; in operation the step
    // waits only for what it needed beyond that. The offline runner's own wait (message
    // time compressed ~2000x) is counted apart, and the worker's time too.
    const double given_s = 1e-6 * static_cast<double>(last_step_utime_ - batch_start_utime_);
    const double wait_in_operation_s = std::max(0.0, result->batch_compute_s - given_s);
    dt += wait_in_operation_s - result->batch_wait_s;
    step_cost_s_ += wait_in_operation_s - result->batch_wait_s;
    step_cpu_s_ += wait_in_operation_s;  // a blocked thread uses no CPU
    ++stats_.timing.background_batches;
    stats_.timing.background_batch_s += result->batch_compute_s;
    stats_.timing.background_wait_s += result->batch_wait_s;
  }
  stats_.timing.solver_s += dt;
  stats_.timing.update_s.push_back(dt);
  stats_.timing.update_utime.push_back(last_step_utime_);
  for (size_t k = 0; k < pending_pairs_.size(); ++k)
    if (pending_pairs_[k].first >= 0)
      pair_factor_[pending_pairs_[k]].push_back(result->new_factor_ids[pending_factor_slot_[k]]);
  std::vector<int64_t> added;
  for (const auto& [key, value] : pending_update_.new_variables) added.push_back(key);
  pending_update_ = {};
  pending_pairs_.clear();
  pending_factor_slot_.clear();
  stats_.factors = static_cast<int64_t>(pair_factor_.size());
  // The partition index follows the estimate after batch steps; in between only new nodes
  // join the index (cells are 1 m: the shift of old nodes between two batch steps, after a
  // loop closure, moves few of them across a cell edge). A rebuild at every update would
  // cost O(nodes) each time. After a background batch the old nodes are re-filed over the
  // next steps, cell_refresh_per_step at a time; a synchronous batch step (the first update,
  // a restored map, a removal outside the schedule) rebuilds at once.
  const auto t1 = Clock::now();
  for (int64_t id : added) fileInCell(id, cellOf(nodePose(id), nodes_[id].floor));
  stats_.timing.partition_s += secondsSince(t1);
  if (result->batch) rebuildCells();
  if (result->batch_swapped) refresh_next_ = 0;
}

void Mapper::sendRequest(int8_t mode, int64_t target) {
  register_request_t r{};
  r.utime = in_flight_->keyframe_utime;
  r.request_id = next_request_id_++;
  r.keyframe_utime = in_flight_->keyframe_utime;
  r.mode = mode;
  r.target_node_id = mode == register_request_t::MODE_NODE ? target : -1;
  r.floor = floor_;
  // A restored mapper's floor is a guess (its newest node's) until a FLOOR message or a
  // relocalisation confirms it: every other global search, the first included, covers every
  // floor (a session may begin on any floor; a restarted mapper is likely on the guessed one).
  if (!floor_confirmed_ && mode == register_request_t::MODE_GLOBAL && ++unconfirmed_searches_ % 2 == 1) r.floor = -1;
  r.session = session_;
  in_flight_->request_id = r.request_id;
  in_flight_->mode = mode;
  (mode == register_request_t::MODE_NODE ? stats_.requests_node : stats_.requests_global)++;
  requests_.push_back(r);
}

void Mapper::step(int64_t keyframe_utime) {
  const auto t0 = Clock::now();
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
  } else if (o_.full_graph) {
    target = nodeInCell(cellOf(world_T_body, floor_), keyframe_utime - micros(o_.recent_exclusion_s));
  } else {
    target = nodeAt(world_T_body, floor_, keyframe_utime);
    // The active node, unless a ride left it on another floor (the cab it was made in looks
    // the same on every floor).
    if (!target && nodes_[static_cast<size_t>(active_)].floor == floor_) target = active_;
  }
  if (target) sendRequest(register_request_t::MODE_NODE, *target);
  else sendRequest(register_request_t::MODE_GLOBAL, -1);
  step_cost_s_ += secondsSince(t0);
  step_cpu_s_ += threadCpuSeconds() - c0;
}

void Mapper::checkTimeout(int64_t utime) {
  if (in_flight_ && utime - in_flight_->sent_utime > micros(o_.request_timeout_s)) {
    // A late result for the closed step is dropped as "no such request in flight".
    ++stats_.timeouts;
    finishStep(false);
  }
}

Status Mapper::onRegisterResult(const register_result_t& msg) {
  if (!in_flight_ || msg.request_id != in_flight_->request_id ||
      msg.keyframe_utime != in_flight_->keyframe_utime) {
    ++stats_.dropped;
    return makeError("REGISTER_RESULT ", msg.request_id, ": no such request in flight");
  }
  const auto t0 = Clock::now();
  const double c0 = threadCpuSeconds();
  if (msg.status != register_result_t::STATUS_OK) {
    if (in_flight_->mode == register_request_t::MODE_NODE && !in_flight_->same_frame_check) {
      sendRequest(register_request_t::MODE_GLOBAL, -1);  // then the global search
      step_cost_s_ += secondsSince(t0);
      step_cpu_s_ += threadCpuSeconds() - c0;
    } else {
      step_cost_s_ += secondsSince(t0);
      step_cpu_s_ += threadCpuSeconds() - c0;
      finishStep(false);
    }
    return Ok{};
  }
  const InFlight f = *in_flight_;
  if (msg.node_id >= 0 && msg.node_id < static_cast<int64_t>(nodes_.size()) && floor_confirmed_ &&
      nodes_[static_cast<size_t>(msg.node_id)].floor != floor_) {
    // A place on another floor: the elevator cab, or a floor that looks like this one.
    ++stats_.rejected_floor;
    stats_.timing.registration_s += secondsSince(t0);
    step_cost_s_ += secondsSince(t0);
    step_cpu_s_ += threadCpuSeconds() - c0;
    finishStep(false);
    return Ok{};
  }
  bool registered = false;
  std::optional<int64_t> same_frame_target;
  Status status = Ok{};
  bool finite = std::isfinite(msg.translation[0]) && std::isfinite(msg.translation[1]) &&
                std::isfinite(msg.translation[2]);
  for (double q : msg.orientation) finite = finite && std::isfinite(q);
  const double q_norm = Eigen::Vector4d(msg.orientation[0], msg.orientation[1], msg.orientation[2], msg.orientation[3]).norm();
  auto cov = covarianceFromMessage(msg.covariance, "REGISTER_RESULT");
  if (!finite || std::abs(q_norm - 1.0) > 1e-3 || !cov || msg.node_id < 0 ||
      msg.node_id >= static_cast<int64_t>(nodes_.size())) {
    ++stats_.dropped;
    status = makeError("REGISTER_RESULT ", msg.request_id, ": malformed pose, covariance or node id");
  } else {
    ++stats_.registrations_ok;
    same_frame_target = handleRegistration(msg, f, *cov, &registered);
    if (same_frame_target) {
      // The new candidate checked at once, on the same keyframe, against a node linked to its
      // node: the step stays open for that answer (once per keyframe).
      in_flight_->same_frame_check = true;
      sendRequest(register_request_t::MODE_NODE, *same_frame_target);
      ++stats_.relocalization_same_frame_checks;
    }
  }
  stats_.timing.registration_s += secondsSince(t0);
  step_cost_s_ += secondsSince(t0);
  step_cpu_s_ += threadCpuSeconds() - c0;
  if (!same_frame_target) finishStep(registered);
  return status;
}

std::optional<int64_t> Mapper::handleRegistration(const register_result_t& msg, const InFlight& f,
                                                  const core::Mat6& cam_cov, bool* registered) {
  const int64_t b = msg.node_id;
  const Eigen::Quaterniond q(msg.orientation[0], msg.orientation[1], msg.orientation[2], msg.orientation[3]);
  const core::SE3d cam_T = core::SE3d(q.normalized(), core::Vec3(msg.translation[0], msg.translation[1], msg.translation[2]));
  const core::SE3d& A = tracker_.bodyTCamera();  // STEREO_CALIB's, once it came
  const core::Mat6 ad = A.adjoint();
  core::UncertainPose b_T_q;  // registration, body frames (paper eq. 9)
  b_T_q.mean = A * cam_T * A.inverse();
  b_T_q.covariance = ad * cam_cov * ad.transpose();
  const auto q_T_now = tracker_.sinceKeyframe(f.keyframe_utime);
  if (!q_T_now) {
    ++stats_.dropped;
    return std::nullopt;
  }
  if (lost_) {
    // One global match may be a false one, and nothing in the map could contradict a wrong
    // placement of the whole session afterwards: the session is placed only when two
    // registrations, chained by odometry, agree on where it is.
    if (!confirmsRelocalization(b, b_T_q, f.keyframe_utime, relocalization_candidate_)) {
      relocalization_candidate_ = RelocalizationCandidate{b, b_T_q, f.keyframe_utime};
      // The check that needs no motion: the same keyframe against a node the map links to b,
      // where that placement says it is seen. Without it the first check waited for the next
      // keyframe, which a robot starting slowly makes seconds later, often past the place.
      if (!f.same_frame_check && o_.relocalization_checks > 0)
        return linkedNeighbour(b, nodePose(b) * b_T_q.mean);
      return std::nullopt;
    }
    relocalization_candidate_.reset();
    *registered = true;
    if (!floor_confirmed_) {
      // A restarted mapper that no FLOOR message has told its floor: the map's node says it.
      floor_ = nodes_[static_cast<size_t>(b)].floor;
      const auto height = floors_.find(floor_);
      floor_height_m_ = height != floors_.end() ? height->second : nodePose(b).translation().z();
      have_floor_ = true;
      floor_confirmed_ = true;
    }
    // Re-localisation: b becomes active, no constraint (Δ had no meaning before it).
    active_ = b;
    tracker_.reset(core::compound(b_T_q, *q_T_now));
    lost_ = false;
    relocalize_ = false;
    ++stats_.relocalizations;
    return std::nullopt;
  }
  if (o_.full_graph) {
    if (nodes_[b].keyframe_utime > f.keyframe_utime - micros(o_.recent_exclusion_s)) return std::nullopt;
    addConstraint(f.active, b, core::compound(f.delta_at_keyframe, core::invert(b_T_q)), ConstraintKind::kLoop,
                  f.keyframe_utime);
    ++stats_.loop_closures;
    *registered = true;
    return std::nullopt;
  }
  *registered = true;
  if (b == f.active) {
    // A registration that contradicts the tracked Δ is not trusted with it (a false match),
    // unless a second one confirms it: then Δ is what was wrong, and it is replaced.
    if (o_.map_gate > 0 && ConstraintSet::mahalanobis2(f.delta_at_keyframe, b_T_q) > o_.map_gate) {
      if (!confirmsRejected(b, b_T_q, f.keyframe_utime, jumpM(f.active, f.delta_at_keyframe, b, b_T_q))) {
        ++stats_.rejected_map_gate;
        gate_rejected_ = true;
        *registered = false;
        return std::nullopt;
      }
      relocalize_ = true;
    }
    rejected_candidate_.reset();
    if (o_.fuse_active_registration && !relocalize_) {
      // Δ (odometry since the active node was last re-localised) and the registration are
      // independent measurements of active_T_keyframe: their information-weighted fusion
      // keeps both. Keeping only one (below) loses, e.g., VO's better heading whenever the
      // registration has the smaller det(Σ), and the graph drifts faster than VO alone.
      tracker_.reset(core::compound(ConstraintSet::fuse(f.delta_at_keyframe, b_T_q), *q_T_now));
      ++stats_.delta_fused;
      return std::nullopt;
    }
    // Entropy test of section III-B.3: keep the better-determined estimate of Δ.
    if (relocalize_ || f.delta_at_keyframe.covariance.determinant() > b_T_q.covariance.determinant()) {
      tracker_.reset(core::compound(b_T_q, *q_T_now));
      relocalize_ = false;
      ++stats_.delta_replaced;
    } else {
      ++stats_.delta_kept;
    }
    return std::nullopt;
  }
  const core::UncertainPose a_T_b = core::compound(f.delta_at_keyframe, core::invert(b_T_q));
  // A pair that already holds constraints tests a new one against them (constraint_set.h);
  // the map gate is for a pair's first constraint, which nothing else can contradict.
  const bool known_pair = constraints_.pairs().count({std::min(f.active, b), std::max(f.active, b)}) > 0;
  double information = std::numeric_limits<double>::infinity();
  const bool contradicts_map = !known_pair && !consistentWithMap(f.active, b, a_T_b, &information);
  if (contradicts_map && !confirmsRejected(b, b_T_q, f.keyframe_utime, jumpM(f.active, f.delta_at_keyframe, b, b_T_q))) {
    ++stats_.rejected_map_gate;
    gate_rejected_ = true;
    *registered = false;
    return std::nullopt;
  }
  rejected_candidate_.reset();
  if (contradicts_map) {
    // Gate recovery: two registrations agree that the robot is at b, against the map and Δ.
    // The closure a → b would carry Δ's error into the map: b becomes active, no constraint
    // (as a new session is placed on the map).
    active_ = b;
    tracker_.reset(core::compound(b_T_q, *q_T_now));
    relocalize_ = false;
    return std::nullopt;
  }
  if (!known_pair && information < o_.min_closure_information) {
    // The map already holds what this closure says about the pair: re-localised on b, no
    // factor (MapperOptions::min_closure_information).
    ++stats_.closures_uninformative;
    active_ = b;
    tracker_.reset(core::compound(b_T_q, *q_T_now));
    relocalize_ = false;
    return std::nullopt;
  }
  const size_t rejected_before = constraints_.rejected();
  // The chain active → keyframe → b, compounded (eq. 6-7): a constraint between existing nodes.
  addConstraint(f.active, b, a_T_b, ConstraintKind::kLoop, f.keyframe_utime, o_.map_gate > 0);
  if (constraints_.rejected() != static_cast<int64_t>(rejected_before)) {
    *registered = false;  // an inconsistent closure: neither the map nor Δ trusts it
    return std::nullopt;
  }
  ++stats_.loop_closures;
  active_ = b;
  tracker_.reset(core::compound(b_T_q, *q_T_now));
  // Δ now reuses the registration the constraint holds: re-localise at the next chance.
  relocalize_ = true;
  return std::nullopt;
}

double Mapper::jumpM(int64_t a, const core::UncertainPose& a_T_q, int64_t b, const core::UncertainPose& b_T_q) const {
  return ((nodePose(a) * a_T_q.mean).translation() - (nodePose(b) * b_T_q.mean).translation()).norm();
}

bool Mapper::confirmsRejected(int64_t b, const core::UncertainPose& b_T_q, int64_t keyframe_utime, double jump_m) {
  // A registration the gate rejects says either that it is a false match or that the map's
  // idea of where the robot is (Δ, or the chain of nodes made since the last closure) went
  // wrong, e.g. after a VO failure longer than its covariance admits. Two rejected
  // registrations that agree with each other through odometry tell the two apart: false
  // matches do not agree. Without this a wrong chain rejects every later closure, and the
  // mapper adds nodes over mapped places until the session ends.
  // Repeated texture (floor tiles) makes false matches that agree with each other: a Δ that
  // registrations keep confirming, with no gap bridged since, is not overridden by them.
  bool agree =
      recoveryAllowed(keyframe_utime) && confirmsRelocalization(b, b_T_q, keyframe_utime, rejected_candidate_);
  // Agreeing registrations one texture period away: not a drift odometry could have made.
  const double drift_m =
      o_.recovery_slack_m + o_.recovery_drift_fraction * (tracker_.odometerM() - odometer_at_confirmation_);
  if (agree && jump_m > drift_m) {
    ++stats_.recoveries_too_far;
    agree = false;
  }
  if (agree) {
    ++stats_.gate_recoveries;
    rejected_candidate_.reset();
  } else {
    rejected_candidate_ = RelocalizationCandidate{b, b_T_q, keyframe_utime};
  }
  return agree;
}

std::optional<int64_t> Mapper::relocalizationCheck(int64_t keyframe_utime) {
  // A lost robot's candidate placement is checked where it predicts the robot is now: a
  // node-mode request to the node of that place (the candidate's own node when none is
  // there), while the robot is still near it, instead of waiting for a second global search
  // to find the same place by appearance (a session that starts where an earlier one
  // started passes one place of the map in its first seconds). Two checks at most, then
  // global searches again (a false candidate cannot hold the search).
  if (!relocalization_candidate_ || relocalization_candidate_->verifications >= o_.relocalization_checks)
    return std::nullopt;
  RelocalizationCandidate& c = *relocalization_candidate_;
  const auto c_T_now = tracker_.sinceKeyframe(c.keyframe_utime);
  if (!c_T_now || c.node < 0 || c.node >= static_cast<int64_t>(nodes_.size())) return std::nullopt;
  ++c.verifications;
  const int floor = nodes_[static_cast<size_t>(c.node)].floor;
  const core::SE3d world_T_body = nodePose(c.node) * c.node_T_keyframe.mean * c_T_now->mean;
  const std::optional<int64_t> target = nodeAt(world_T_body, floor, keyframe_utime);
  return target ? target : std::optional<int64_t>(c.node);
}

std::optional<int64_t> Mapper::linkedNeighbour(int64_t node, const core::SE3d& world_T_body) const {
  const double heading_rad = overlapHeadingRad();
  const core::SE2d p = core::toPlanar(world_T_body);
  std::optional<int64_t> best;
  double best_m = std::numeric_limits<double>::infinity();
  for (const auto& [key, pair] : constraints_.pairs()) {
    if (key.first != node && key.second != node) continue;
    const int64_t other = key.first == node ? key.second : key.first;
    if (other < 0 || other >= static_cast<int64_t>(nodes_.size()) ||
        nodes_[static_cast<size_t>(other)].floor != nodes_[static_cast<size_t>(node)].floor)
      continue;
    const core::SE2d q = core::toPlanar(nodePose(other));
    if (headingApartRad(q, p) > heading_rad) continue;
    const double d = std::hypot(q.x() - p.x(), q.y() - p.y());
    if (d < best_m) {
      best_m = d;
      best = other;
    }
  }
  return best;
}

std::optional<int64_t> Mapper::nodeAt(const core::SE3d& world_T_body, int floor, int64_t newest_allowed) const {
  if (auto id = nodeInCell(cellOf(world_T_body, floor), newest_allowed)) return id;
  return overlappingNode(world_T_body, floor, newest_allowed);
}

bool Mapper::confirmsRelocalization(int64_t b, const core::UncertainPose& b_T_q, int64_t keyframe_utime,
                                    const std::optional<RelocalizationCandidate>& candidate) {
  if (!candidate) return false;
  const RelocalizationCandidate c = *candidate;
  const auto c_T_now = tracker_.sinceKeyframe(c.keyframe_utime);
  const auto q_T_now = tracker_.sinceKeyframe(keyframe_utime);
  if (!c_T_now || !q_T_now) return false;  // too old: the newer one becomes the candidate
  // The two placements chained: c.node_T_b = c.node_T_kc ⊕ kc_T_q ⊕ ⊖(b_T_q) (eq. 6-7; the
  // odometry covariance is counted twice where the two chains share increments: a looser gate).
  const core::UncertainPose kc_T_q = core::compound(*c_T_now, core::invert(*q_T_now));
  const core::UncertainPose measured = core::compound(core::compound(c.node_T_keyframe, kc_T_q), core::invert(b_T_q));
  bool agree = false;
  if (c.node == b) {
    agree = !(o_.map_gate > 0) || ConstraintSet::mahalanobis2(core::UncertainPose{}, measured) <= o_.map_gate;
  } else {
    agree = consistentWithMap(c.node, b, measured);
  }
  if (!agree) ++stats_.relocalization_disagreements;
  return agree;
}

bool Mapper::consistentWithMap(int64_t a, int64_t b, const core::UncertainPose& a_T_b, double* information) {
  if (information) *information = std::numeric_limits<double>::infinity();
  if (!(o_.map_gate > 0)) return true;
  // The map's own estimate of a_T_b with its marginal covariance (the joint marginal of a and
  // b through the relative-pose Jacobians), against the measured chain.
  const auto t0 = Clock::now();
  // From the solver's current factor by path solves (no copy of R): the work follows the
  // two nodes' elimination-tree paths, not the size of the map.
  const std::vector<solver::Key> keys{a, b};
  auto joint = solver::Marginals::jointOf(solver_, keys);
  stats_.timing.registration_s += secondsSince(t0);
  if (!joint) return true;  // no marginal: nothing to test against
  core::Mat6 Ja, Jb;
  core::UncertainPose predicted;
  predicted.mean = core::between(nodePose(a), nodePose(b), &Ja, &Jb);
  Eigen::Matrix<double, 6, 12> J;
  J << Ja, Jb;
  predicted.covariance = J * (*joint) * J.transpose();
  if (information) {
    // ½ ln det(Σ_map + Σ_z) / det(Σ_z) from Cholesky factors (both positive definite).
    const Eigen::LLT<core::Mat6> sum(predicted.covariance + a_T_b.covariance);
    const Eigen::LLT<core::Mat6> z(a_T_b.covariance);
    if (sum.info() == Eigen::Success && z.info() == Eigen::Success) {
      double half_log_ratio = 0.0;
      for (int k = 0; k < 6; ++k)
        half_log_ratio += std::log(sum.matrixLLT()(k, k)) - std::log(z.matrixLLT()(k, k));
      *information = half_log_ratio;
    }
  }
  return ConstraintSet::mahalanobis2(predicted, a_T_b) <= o_.map_gate;
}

int64_t Mapper::bridges() const {
  const TrackerCounts& c = tracker_.counts();
  return c.wheel_applied + c.restarts + c.reanchored + c.relinks_refused + c.relinks_weaker + rides_;
}

bool Mapper::recoveryAllowed(int64_t keyframe_utime) const {
  // Odometry bridged a gap since the last registration that confirmed it, or registrations
  // have stopped confirming it for recovery_quiet_s.
  return last_confirmed_utime_ < 0 || bridges() != bridges_at_confirmation_ ||
         keyframe_utime - last_confirmed_utime_ >= micros(o_.recovery_quiet_s);
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
  const auto t0 = Clock::now();
  const double c0 = threadCpuSeconds();
  if (lost_) {
    // Not re-localised yet: neither a node nor a step pose from a meaningless Δ.
    stats_.timing.partition_s += secondsSince(t0);
    stats_.timing.step_cost.push_back({f.keyframe_utime, step_cost_s_ + secondsSince(t0), step_cpu_s_ + threadCpuSeconds() - c0});
    return;
  }
  // A registration the gate rejected still says a node is near (or it is a false match, and
  // the next step adds the node): no new node at this step.
  if (!registered && !gate_rejected && !o_.full_graph) {
    const core::SE3d world_T_body = nodePose(f.active) * f.delta_at_keyframe.mean;
    if (!nodeAt(world_T_body, floor_, f.keyframe_utime)) {
      // A new place (eq. 8): the node at the keyframe, then Δ restarts from it.
      addNode(f.keyframe_utime, f.delta_at_keyframe);
      tracker_.reset(tracker_.sinceKeyframe(f.keyframe_utime).value_or(core::UncertainPose{}));
      relocalize_ = false;
    }
  }
  stats_.timing.partition_s += secondsSince(t0);
  flushSolver();
  const auto q_T_now = tracker_.sinceKeyframe(f.keyframe_utime);
  const core::SE3d node_T_q = tracker_.delta().mean * (q_T_now ? q_T_now->mean.inverse() : core::SE3d());
  step_poses_.push_back(StepPose{f.keyframe_utime, active_, node_T_q, session_});
  stats_.timing.step_cost.push_back({f.keyframe_utime, step_cost_s_ + secondsSince(t0), step_cpu_s_ + threadCpuSeconds() - c0});
}

Status Mapper::restore(const MapSnapshot& map) {
  if (!nodes_.empty() || have_floor_) return Error{"mapper: restore: the mapper already holds a map"};
  std::map<int, double> floors(map.floors.begin(), map.floors.end());
  int max_session = -1;
  for (const auto& [session, start] : map.sessions) max_session = std::max(max_session, session);
  for (size_t k = 0; k < map.nodes.size(); ++k) {
    const StoredNode& n = map.nodes[k];
    if (n.node.id != static_cast<int64_t>(k))
      return makeError("mapper: restore: node ", n.node.id, " where node ", k, " was expected");
    max_session = std::max(max_session, n.node.session);
    pending_update_.new_variables.emplace_back(n.node.id, solver::PoseValue::spatial(n.world_T_body));
    if (k == 0) {
      // The origin stays where the first session put it.
      Eigen::MatrixXd W = Eigen::MatrixXd::Zero(6, 6);
      W.diagonal() << core::Vec3::Constant(1.0 / o_.origin_sigma_m), core::Vec3::Constant(1.0 / o_.origin_sigma_rad);
      pending_update_.new_factors.push_back(std::make_shared<solver::PosePrior3Factor>(0, n.world_T_body, W));
      pending_pairs_.emplace_back(-1, -1);
      pending_factor_slot_.push_back(pending_update_.new_factors.size() - 1);
    }
    const auto height = floors.find(n.node.floor);
    if (o_.height_factors && height != floors.end()) {
      pending_update_.new_factors.push_back(std::make_shared<solver::HeightFactor>(n.node.id, height->second, 0.02));
      pending_pairs_.emplace_back(-1, -1);
      pending_factor_slot_.push_back(pending_update_.new_factors.size() - 1);
    }
    MapperNode node = n.node;
    if (node.attitude && !(o_.attitude_factors && addAttitudeFactor(node.id, *node.attitude))) node.attitude.reset();
    nodes_.push_back(node);
  }
  const auto n_nodes = static_cast<int64_t>(nodes_.size());
  for (size_t k = 0; k < map.edges.size(); ++k) {
    const Constraint& c = map.edges[k].constraint;
    // In the order they were made (a fold comes before its pair's later constraints).
    if ((k > 0 && map.edges[k].edge_id <= map.edges[k - 1].edge_id) || c.from < 0 || c.to < 0 || c.from >= n_nodes ||
        c.to >= n_nodes || c.from == c.to) {
      nodes_.clear();
      pending_update_ = {};
      return makeError("mapper: restore: edge ", map.edges[k].edge_id, " (", c.from, " -> ", c.to,
                       ") is out of order or names an unknown node");
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
  return Ok{};
}

}  // namespace evermap::mapper
