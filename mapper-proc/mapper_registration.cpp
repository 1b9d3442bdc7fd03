// Algorithm 1's registration protocol (mapper.h): the requests a step sends to loopclose-proc
// and what the mapper does with the answers. A registration to the active node refines Δ, one
// to another node closes a loop (eq. 6-7); the map gate tests a pair's first constraint
// against the map's marginals, and two rejected registrations that agree through odometry
// override the map (gate recovery); a lost session is placed by two that agree.

#include "mapper-proc/mapper.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Cholesky>

#include "core/common/clocks.h"
#include "core/messages/pose_fields.h"
#include "core/solver/marginals.h"

namespace evermap::mapper {

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
  if (!floor_confirmed_ && mode == register_request_t::MODE_GLOBAL &&
      ++unconfirmed_searches_ % 2 == 1)
    r.floor = -1;
  r.session = session_;
  in_flight_->request_id = r.request_id;
  in_flight_->mode = mode;
  (mode == register_request_t::MODE_NODE ? stats_.requests_node : stats_.requests_global)++;
  requests_.push_back(r);
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
  const auto t0 = SteadyClock::now();
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
  const bool pose_ok =
      messages::poseFromMessage(msg.translation, msg.orientation, "REGISTER_RESULT").ok();
  auto cov = messages::covarianceFromMessage(msg.covariance, "REGISTER_RESULT");
  if (!pose_ok || !cov || msg.node_id < 0 || msg.node_id >= static_cast<int64_t>(nodes_.size())) {
    ++stats_.dropped;
    status =
        makeError("REGISTER_RESULT ", msg.request_id, ": malformed pose, covariance or node id");
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
  int64_t b = msg.node_id;
  // Checked by onRegisterResult.
  const Eigen::Quaterniond q = *messages::quaternionFromMessage(msg.orientation, "REGISTER_RESULT");
  const core::SE3d cam_T = core::SE3d(
      q.normalized(), core::Vec3(msg.translation[0], msg.translation[1], msg.translation[2]));
  // The registration in body frames (paper eq. 9), by STEREO_CALIB's mounting once it came.
  core::UncertainPose b_T_q = tracker_.registrationToBody(cam_T, cam_cov);
  registered_via_.reset();
  if (const MapperNode& n = nodes_[static_cast<size_t>(b)]; n.merged_into >= 0) {
    // A merged node's keyframe is a view of the place of the node it is part of: the
    // registration is one to that node (a closure's constraint still names the merged one).
    registered_via_.emplace(b, b_T_q);
    b_T_q.mean = n.into_T_node * b_T_q.mean;
    b = n.merged_into;
  }
  const auto q_T_now = tracker_.sinceKeyframe(f.keyframe_utime);
  if (!q_T_now) {
    ++stats_.dropped;
    return std::nullopt;
  }
  if (lost_) return placeLostSession(f, b, b_T_q, *q_T_now, registered);
  if (resumed_ && b < resume_first_new_node_)
    return confirmResumed(f, b, b_T_q, *q_T_now, registered);
  if (o_.full_graph) {
    if (nodes_[b].keyframe_utime > f.keyframe_utime - micros(o_.recent_exclusion_s))
      return std::nullopt;
    addConstraint(f.active, b, core::compound(f.delta_at_keyframe, core::invert(b_T_q)),
                  ConstraintKind::kLoop, f.keyframe_utime);
    ++stats_.loop_closures;
    *registered = true;
    return std::nullopt;
  }
  *registered = true;
  if (b != f.active && isSatellite(b)) {
    // A node hung off the active node by Δ (node_at_every_new_place): a closure to it would
    // count Δ's registrations twice. Re-localised on it instead, no factor.
    active_ = b;
    tracker_.reset(core::compound(b_T_q, *q_T_now));
    relocalize_ = false;
    return std::nullopt;
  }
  if (b == f.active) {
    registerToActive(f, b_T_q, *q_T_now, registered);
  } else {
    closeLoop(f, b, b_T_q, *q_T_now, registered);
  }
  return std::nullopt;
}

std::optional<int64_t> Mapper::placeLostSession(const InFlight& f, int64_t b,
                                                const core::UncertainPose& b_T_q,
                                                const core::UncertainPose& q_T_now,
                                                bool* registered) {
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
  tracker_.reset(core::compound(b_T_q, q_T_now));
  lost_ = false;
  relocalize_ = false;
  ++stats_.relocalizations;
  return std::nullopt;
}

std::optional<int64_t> Mapper::confirmResumed(const InFlight& f, int64_t b,
                                              const core::UncertainPose& b_T_q,
                                              const core::UncertainPose& q_T_now,
                                              bool* registered) {
  // A warm restart's Δ (or the first node made from it) is the saved pose with the gap's
  // uncertainty: a closure from it would carry the unknown motion of the gap into the map as
  // a measurement (a false loop edge, metres off), and one registration inside so wide a
  // prior is no better evidence than a lost robot's first. So, as for a lost session: the
  // registration must fit the inflated pose (the map gate, with Δ's covariance in the chain
  // a_T_b) and a second one must agree with it through odometry; then the robot is placed.
  const core::UncertainPose a_T_b = core::compound(f.delta_at_keyframe, core::invert(b_T_q));
  const bool fits = b == f.active
                        ? !(o_.map_gate > 0) ||
                              ConstraintSet::mahalanobis2(f.delta_at_keyframe, b_T_q) <= o_.map_gate
                        : consistentWithMap(f.active, b, a_T_b);
  *registered = false;
  gate_rejected_ = true;  // a place of the map is near (or a false match): no node at this step
  if (!fits) {
    ++stats_.warm_rejections;
    return std::nullopt;
  }
  if (!confirmsRelocalization(b, b_T_q, f.keyframe_utime, relocalization_candidate_)) {
    relocalization_candidate_ = RelocalizationCandidate{b, b_T_q, f.keyframe_utime};
    if (!f.same_frame_check && o_.relocalization_checks > 0)
      return linkedNeighbour(b, nodePose(b) * b_T_q.mean);
    return std::nullopt;
  }
  relocalization_candidate_.reset();
  resumed_ = false;
  gate_rejected_ = false;
  *registered = true;
  ++stats_.warm_confirmations;
  if (f.active >= resume_first_new_node_ && b != f.active) {
    // Nodes made since the restart hang on the saved node by the inflated edge: this closure,
    // measured from one of them (Δ since that node is odometry), ties them to the map.
    closeLoop(f, b, b_T_q, q_T_now, registered);
    return std::nullopt;
  }
  // Still on the saved node: placed on b, no constraint (Δ held the gap).
  active_ = b;
  tracker_.reset(core::compound(b_T_q, q_T_now));
  relocalize_ = false;
  return std::nullopt;
}

void Mapper::registerToActive(const InFlight& f, const core::UncertainPose& b_T_q,
                              const core::UncertainPose& q_T_now, bool* registered) {
  const int64_t b = f.active;
  // A registration that contradicts the tracked Δ is not trusted with it (a false match),
  // unless a second one confirms it: then Δ is what was wrong, and it is replaced.
  if (o_.map_gate > 0 && ConstraintSet::mahalanobis2(f.delta_at_keyframe, b_T_q) > o_.map_gate) {
    if (!confirmsRejected(b, b_T_q, f.keyframe_utime,
                          jumpM(f.active, f.delta_at_keyframe, b, b_T_q))) {
      ++stats_.rejected_map_gate;
      gate_rejected_ = true;
      *registered = false;
      return;
    }
    relocalize_ = true;
  }
  rejected_candidate_.reset();
  if (o_.fuse_active_registration && !relocalize_) {
    // Δ (odometry since the active node was last re-localised) and the registration are
    // independent measurements of active_T_keyframe: their information-weighted fusion
    // keeps both. Keeping only one (below) loses, e.g., VO's better heading whenever the
    // registration has the smaller det(Σ), and the graph drifts faster than VO alone.
    registered_active_T_keyframe_ = ConstraintSet::fuse(f.delta_at_keyframe, b_T_q);
    tracker_.reset(core::compound(*registered_active_T_keyframe_, q_T_now));
    ++stats_.delta_fused;
    return;
  }
  // Entropy test of section III-B.3: keep the better-determined estimate of Δ.
  if (relocalize_ ||
      f.delta_at_keyframe.covariance.determinant() > b_T_q.covariance.determinant()) {
    tracker_.reset(core::compound(b_T_q, q_T_now));
    relocalize_ = false;
    ++stats_.delta_replaced;
    registered_active_T_keyframe_ = b_T_q;
  } else {
    ++stats_.delta_kept;
    registered_active_T_keyframe_ = f.delta_at_keyframe;
  }
}

void Mapper::closeLoop(const InFlight& f, int64_t b, const core::UncertainPose& b_T_q,
                       const core::UncertainPose& q_T_now, bool* registered) {
  const core::UncertainPose a_T_b = core::compound(f.delta_at_keyframe, core::invert(b_T_q));
  // A pair that already holds constraints tests a new one against them (constraint_set.h);
  // the map gate is for a pair's first constraint, which nothing else can contradict.
  const bool known_pair =
      constraints_.pairs().count({std::min(f.active, b), std::max(f.active, b)}) > 0;
  double information = std::numeric_limits<double>::infinity();
  const bool contradicts_map = !known_pair && !consistentWithMap(f.active, b, a_T_b, &information);
  if (contradicts_map && !confirmsRejected(b, b_T_q, f.keyframe_utime,
                                           jumpM(f.active, f.delta_at_keyframe, b, b_T_q))) {
    ++stats_.rejected_map_gate;
    gate_rejected_ = true;
    *registered = false;
    return;
  }
  rejected_candidate_.reset();
  if (contradicts_map) {
    // Gate recovery: two registrations agree that the robot is at b, against the map and Δ.
    // The closure a → b would carry Δ's error into the map: b becomes active, no constraint
    // (as a new session is placed on the map).
    active_ = b;
    tracker_.reset(core::compound(b_T_q, q_T_now));
    relocalize_ = false;
    return;
  }
  // A new pair between two nodes that are both tied to as many others as
  // MapperOptions::closure_partners allows needs saturated_closure_information.
  const bool saturated =
      !known_pair && o_.closure_partners > 0 &&
      std::min(constraints_.partners(f.active), constraints_.partners(b)) >= o_.closure_partners;
  const bool uninformative = !known_pair && information < o_.min_closure_information;
  if (uninformative || (saturated && information < o_.saturated_closure_information)) {
    // The map already holds what this closure says about the pair: re-localised on b, no
    // factor (MapperOptions::min_closure_information, closure_partners).
    ++(uninformative ? stats_.closures_uninformative : stats_.closures_saturated);
    active_ = b;
    tracker_.reset(core::compound(b_T_q, q_T_now));
    relocalize_ = false;
    return;
  }
  const size_t rejected_before = constraints_.rejected();
  // The chain active → keyframe → b, compounded (eq. 6-7): a constraint between existing nodes.
  if (registered_via_) {
    // To the merged node the keyframe registered to: a contradiction can then undo the merge.
    const auto& [n, n_T_q] = *registered_via_;
    addConstraint(f.active, n, core::compound(f.delta_at_keyframe, core::invert(n_T_q)),
                  ConstraintKind::kLoop, f.keyframe_utime, o_.map_gate > 0);
  } else {
    addConstraint(f.active, b, a_T_b, ConstraintKind::kLoop, f.keyframe_utime, o_.map_gate > 0);
  }
  if (constraints_.rejected() != static_cast<int64_t>(rejected_before)) {
    *registered = false;  // an inconsistent closure: neither the map nor Δ trusts it
    return;
  }
  ++stats_.loop_closures;
  closed_loop_ = true;
  active_ = b;
  tracker_.reset(core::compound(b_T_q, q_T_now));
  // Δ now reuses the registration the constraint holds: re-localise at the next chance.
  relocalize_ = true;
}

double Mapper::jumpM(int64_t a, const core::UncertainPose& a_T_q, int64_t b,
                     const core::UncertainPose& b_T_q) const {
  return ((nodePose(a) * a_T_q.mean).translation() - (nodePose(b) * b_T_q.mean).translation())
      .norm();
}

bool Mapper::confirmsRejected(int64_t b, const core::UncertainPose& b_T_q, int64_t keyframe_utime,
                              double jump_m) {
  // A registration the gate rejects says either that it is a false match or that the map's
  // idea of where the robot is (Δ, or the chain of nodes made since the last closure) went
  // wrong, e.g. after a VO failure longer than its covariance admits. Two rejected
  // registrations that agree with each other through odometry tell the two apart: false
  // matches do not agree. Without this a wrong chain rejects every later closure, and the
  // mapper adds nodes over mapped places until the session ends.
  // Repeated texture (floor tiles) makes false matches that agree with each other: a Δ that
  // registrations keep confirming, with no gap bridged since, is not overridden by them.
  const bool another_node =
      !o_.recovery_needs_two_nodes || (rejected_candidate_ && rejected_candidate_->node != b);
  bool agree = recoveryAllowed(keyframe_utime) && another_node &&
               confirmsRelocalization(b, b_T_q, keyframe_utime, rejected_candidate_);
  // Agreeing registrations one texture period away: not a drift odometry could have made.
  const double drift_m =
      o_.recovery_slack_m +
      o_.recovery_drift_fraction * (tracker_.odometerM() - odometer_at_confirmation_);
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
  if (!relocalization_candidate_ ||
      relocalization_candidate_->verifications >= o_.relocalization_checks)
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
  const double heading_rad = partition_.overlapHeadingRad();
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
    if (PartitionIndex::headingApartRad(q, p) > heading_rad) continue;
    const double d = std::hypot(q.x() - p.x(), q.y() - p.y());
    if (d < best_m) {
      best_m = d;
      best = other;
    }
  }
  return best;
}

bool Mapper::confirmsRelocalization(int64_t b, const core::UncertainPose& b_T_q,
                                    int64_t keyframe_utime,
                                    const std::optional<RelocalizationCandidate>& candidate) {
  if (!candidate) return false;
  const RelocalizationCandidate c = *candidate;
  const auto c_T_now = tracker_.sinceKeyframe(c.keyframe_utime);
  const auto q_T_now = tracker_.sinceKeyframe(keyframe_utime);
  if (!c_T_now || !q_T_now) return false;  // too old: the newer one becomes the candidate
  // The two placements chained: c.node_T_b = c.node_T_kc ⊕ kc_T_q ⊕ ⊖(b_T_q) (eq. 6-7; the
  // odometry covariance is counted twice where the two chains share increments: a looser gate).
  const core::UncertainPose kc_T_q = core::compound(*c_T_now, core::invert(*q_T_now));
  const core::UncertainPose measured =
      core::compound(core::compound(c.node_T_keyframe, kc_T_q), core::invert(b_T_q));
  bool agree = false;
  if (c.node == b) {
    agree = !(o_.map_gate > 0) ||
            ConstraintSet::mahalanobis2(core::UncertainPose{}, measured) <= o_.map_gate;
  } else {
    agree = consistentWithMap(c.node, b, measured);
  }
  if (!agree) ++stats_.relocalization_disagreements;
  return agree;
}

std::optional<core::UncertainPose> Mapper::mapRelative(int64_t a, int64_t b) const {
  // From the solver's current factor by path solves (no copy of R): the work follows the
  // two nodes' elimination-tree paths, not the size of the map.
  const std::vector<solver::Key> keys{a, b};
  const auto joint = solver::Marginals::jointOf(schedule_.solver(), keys);
  if (!joint) return std::nullopt;
  core::Mat6 Ja, Jb;
  core::UncertainPose predicted;
  predicted.mean = core::between(nodePose(a), nodePose(b), &Ja, &Jb);
  Eigen::Matrix<double, 6, 12> J;
  J << Ja, Jb;
  predicted.covariance = J * (*joint) * J.transpose();
  return predicted;
}

bool Mapper::consistentWithMap(int64_t a, int64_t b, const core::UncertainPose& a_T_b,
                               double* information) {
  if (information) *information = std::numeric_limits<double>::infinity();
  if (!(o_.map_gate > 0)) return true;
  // The map's own estimate of a_T_b with its marginal covariance, against the measured chain.
  const auto t0 = SteadyClock::now();
  const std::optional<core::UncertainPose> map = mapRelative(a, b);
  stats_.timing.registration_s += secondsSince(t0);
  if (!map) return true;  // no marginal: nothing to test against
  const core::UncertainPose& predicted = *map;
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
  return c.wheel_applied + c.restarts + c.reanchored + c.relinks_refused + c.relinks_weaker +
         rides_;
}

bool Mapper::recoveryAllowed(int64_t keyframe_utime) const {
  // Odometry bridged a gap since the last registration that confirmed it, or registrations
  // have stopped confirming it for recovery_quiet_s.
  return last_confirmed_utime_ < 0 || bridges() != bridges_at_confirmation_ ||
         keyframe_utime - last_confirmed_utime_ >= micros(o_.recovery_quiet_s);
}

}  // namespace evermap::mapper
