// Algorithm 1's graph (mapper.h): the nodes, their partial factors (origin prior, floor
// height, IMU roll and pitch), the constraints through the constraint set, and the updates
// that send them to the solver (solver_schedule.h), with the partition index after them.

#include <utility>

#include <Eigen/Cholesky>

#include "core/common/clocks.h"
#include "core/solver/pose_factors.h"
#include "mapper-proc/mapper.h"

namespace evermap::mapper {

int64_t Mapper::addNode(int64_t keyframe_utime, const core::UncertainPose& active_T_node) {
  const int64_t id = static_cast<int64_t>(nodes_.size());
  // The first pose defines the origin (section III-B), at the floor's height.
  const core::SE3d world_T_node =
      active_ >= 0 ? nodePose(active_) * active_T_node.mean
                   : core::SE3d(core::SO3d(), core::Vec3(0, 0, floors_.heightM()));
  schedule_.addVariable(id, world_T_node);
  if (active_ < 0)
    addOriginPrior(id, world_T_node);
  else
    addConstraint(active_, id, active_T_node, ConstraintKind::kOdometry, keyframe_utime);
  if (o_.height_factors && floors_.known()) {
    schedule_.addFactor(std::make_shared<solver::HeightFactor>(id, floors_.heightM(), 0.02));
  }
  MapperNode node{id, keyframe_utime, floors_.floor(), session_, std::nullopt};
  if (const auto a = attitudeAt(keyframe_utime); a && addAttitudeFactor(id, *a)) node.attitude = a;
  nodes_.push_back(node);
  floors_.nodesOn(node.floor, 1);
  node_added_t msg{};
  msg.utime = keyframe_utime;
  msg.node_id = id;
  msg.keyframe_utime = keyframe_utime;
  msg.floor = floors_.floor();
  msg.session = session_;
  nodes_added_.push_back(msg);
  active_ = id;
  ++stats_.nodes;
  return id;
}

std::optional<NodeAttitude> Mapper::attitudeAt(int64_t keyframe_utime) const {
  if (!o_.attitude_factors || !attitude_ || keyframe_utime - attitude_->utime > micros(1.0))
    return std::nullopt;
  NodeAttitude a;
  a.roll_rad = attitude_->roll_rad;
  a.pitch_rad = attitude_->pitch_rad;
  a.covariance << attitude_->covariance[0], attitude_->covariance[1], attitude_->covariance[2],
      attitude_->covariance[3];
  return a;
}

void Mapper::addOriginPrior(int64_t id, const core::SE3d& world_T_node) {
  Eigen::MatrixXd W = Eigen::MatrixXd::Zero(6, 6);
  W.diagonal() << core::Vec3::Constant(1.0 / o_.origin_sigma_m),
      core::Vec3::Constant(1.0 / o_.origin_sigma_rad);
  schedule_.addFactor(std::make_shared<solver::PosePrior3Factor>(id, world_T_node, W));
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
  const bool refreshed = partition_.refresh(nodes_, schedule_.solver());
  if (footprints_.refresh(poses()) || refreshed)
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
    partition_.file(id, partition_.cellOf(nodePose(id), nodes_[static_cast<size_t>(id)].floor));
  if (flush.batch) {
    partition_.rebuild(nodes_, schedule_.solver().estimate());
    footprints_.rebuild(poses());
  }
  if (flush.batch_swapped) {
    partition_.startRefresh();
    footprints_.startRefresh();
  }
  stats_.timing.partition_s += secondsSince(t1);
}

std::optional<int64_t> Mapper::nodeAt(const core::SE3d& world_T_body, int floor,
                                      int64_t newest_allowed) const {
  if (auto id = partition_.nodeAt(world_T_body, floor, newest_allowed, nodes_, schedule_.solver()))
    return id;
  if (!o_.footprints) return std::nullopt;
  return footprints_.nodeAt(world_T_body, floor, session_);
}

ViewFootprints::NodePoses Mapper::poses() const {
  return [this](int64_t id) { return nodePose(id); };
}

void Mapper::addFootprint(const Footprint& view, int64_t keyframe_utime) {
  // Only where no node serves the place (add() refuses where a footprint covers it).
  // Kept planar, as the store keeps it, so that a restored map files it in the same cell.
  const Footprint planar{view.node, core::fromPlanar(core::toPlanar(view.node_T_view)), session_};
  const int floor = nodes_[static_cast<size_t>(view.node)].floor;
  const core::SE3d world_T_view = nodePose(view.node) * planar.node_T_view;
  if (partition_.nodeAt(world_T_view, floor, keyframe_utime, nodes_, schedule_.solver())) return;
  if (footprints_.add(planar, world_T_view, floor)) ++stats_.footprints;
}

}  // namespace evermap::mapper
