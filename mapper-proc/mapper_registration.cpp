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
  // A restored mapper's floor is a guess (its newest node's) until a FLOOR message or a
  // relocalisation confirms it: every other global search, the first included, covers every
  // floor (a session may begin on any floor; a restarted mapper is likely on the guessed one).
  const int floor =
      mode == register_request_t::MODE_GLOBAL ? floors_.searchFloor() : floors_.floor();
  const register_request_t& r =
      queueRequest(in_flight_->keyframe_utime, mode, target, floor, session_);
  in_flight_->request_id = r.request_id;
  in_flight_->mode = mode;
  (mode == register_request_t::MODE_NODE ? stats_.requests_node : stats_.requests_global)++;
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
      addStepCost(t0, c0);
    } else {
      addStepCost(t0, c0);
      finishStep(false);
    }
    return Ok{};
  }
  const InFlight f = *in_flight_;
  if (quarantined(msg.node_id)) {
    // A place of a quarantined session: not part of the map (startSession).
    ++stats_.registrations_quarantined;
    addStepCost(t0, c0);
    finishStep(false);
    return Ok{};
  }
  if (msg.node_id >= 0 && msg.node_id < static_cast<int64_t>(nodes_.size()) &&
      floors_.confirmed() && nodes_[static_cast<size_t>(msg.node_id)].floor != floors_.floor()) {
    // A place on another floor: the elevator cab, or a floor that looks like this one.
    ++stats_.rejected_floor;
    stats_.timing.registration_s += secondsSince(t0);
    addStepCost(t0, c0);
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
  addStepCost(t0, c0);
  if (!same_frame_target) finishStep(registered);
  return status;
}

std::optional<int64_t> Mapper::handleRegistration(const register_result_t& msg, const InFlight& f,
                                                  const core::Mat6& cam_cov, bool* registered) {
  const int64_t b = msg.node_id;
  // Checked by onRegisterResult.
  const Eigen::Quaterniond q = *messages::quaternionFromMessage(msg.orientation, "REGISTER_RESULT");
  const core::SE3d cam_T = core::SE3d(
      q.normalized(), core::Vec3(msg.translation[0], msg.translation[1], msg.translation[2]));
  // The registration in body frames (paper eq. 9), by STEREO_CALIB's mounting once it came.
  const core::UncertainPose b_T_q = tracker_.registrationToBody(cam_T, cam_cov);
  const auto q_T_now = tracker_.sinceKeyframe(f.keyframe_utime);
  if (!q_T_now) {
    ++stats_.dropped;
    return std::nullopt;
  }
  if (lost_) return placeLostSession(f, b, b_T_q, *q_T_now, registered);
  if (warm_.unconfirmed() && warm_.restoredNode(b))
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
  if (b == f.active) {
    registerToActive(f, b_T_q, *q_T_now, registered);
  } else {
    closeLoop(f, b, b_T_q, *q_T_now, registered);
  }
  if (*registered) in_flight_->view = Footprint{b, b_T_q.mean, session_};
  return std::nullopt;
}

std::optional<int64_t> Mapper::placeLostSession(const InFlight& f, int64_t b,
                                                const core::UncertainPose& b_T_q,
                                                const core::UncertainPose& q_T_now,
                                                bool* registered) {
  // One global match may be a false one, and nothing in the map could contradict a wrong
  // placement of the whole session afterwards: the session is placed only when two
  // registrations, chained by odometry, agree on where it is.
  std::optional<int64_t> check;
  if (!confirmsCandidate(f, b, b_T_q, &check)) return check;
  *registered = true;
  if (!floors_.confirmed()) {
    // A restarted mapper that no FLOOR message has told its floor: the map's node says it.
    floors_.placeOn(nodes_[static_cast<size_t>(b)].floor, nodePose(b).translation().z());
  }
  // Re-localisation: b becomes active, no constraint (Δ had no meaning before it).
  relocalizeOn(b, b_T_q, q_T_now);
  lost_ = false;
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
  const bool fits = b == f.active ? map_gate_.agree(f.delta_at_keyframe, b_T_q)
                                  : consistentWithMap(f.active, b, a_T_b);
  *registered = false;
  gate_rejected_ = true;  // a place of the map is near (or a false match): no node at this step
  if (!fits) {
    ++stats_.warm_rejections;
    return std::nullopt;
  }
  std::optional<int64_t> check;
  if (!confirmsCandidate(f, b, b_T_q, &check)) return check;
  warm_.confirmed();
  gate_rejected_ = false;
  *registered = true;
  ++stats_.warm_confirmations;
  if (!warm_.restoredNode(f.active) && b != f.active) {
    // Nodes made since the restart hang on the saved node by the inflated edge: this closure,
    // measured from one of them (Δ since that node is odometry), ties them to the map.
    closeLoop(f, b, b_T_q, q_T_now, registered);
    return std::nullopt;
  }
  // Still on the saved node: placed on b, no constraint (Δ held the gap).
  relocalizeOn(b, b_T_q, q_T_now);
  return std::nullopt;
}

void Mapper::registerToActive(const InFlight& f, const core::UncertainPose& b_T_q,
                              const core::UncertainPose& q_T_now, bool* registered) {
  const int64_t b = f.active;
  // A registration that contradicts the tracked Δ is not trusted with it (a false match),
  // unless a second one confirms it: then Δ is what was wrong, and it is replaced.
  if (!map_gate_.agree(f.delta_at_keyframe, b_T_q)) {
    if (!confirmsRejected(b, b_T_q, f.keyframe_utime,
                          jumpM(f.active, f.delta_at_keyframe, b, b_T_q))) {
      ++stats_.rejected_map_gate;
      gate_rejected_ = true;
      *registered = false;
      return;
    }
    relocalize_ = true;
  }
  recovery_.rejected().reset();
  if (o_.fuse_active_registration && !relocalize_) {
    // Δ (odometry since the active node was last re-localised) and the registration are
    // independent measurements of active_T_keyframe: their information-weighted fusion
    // keeps both. Keeping only one (below) loses, e.g., VO's better heading whenever the
    // registration has the smaller det(Σ), and the graph drifts faster than VO alone.
    tracker_.reset(core::compound(ConstraintSet::fuse(f.delta_at_keyframe, b_T_q), q_T_now));
    ++stats_.delta_fused;
    return;
  }
  // Entropy test of section III-B.3: keep the better-determined estimate of Δ.
  if (relocalize_ ||
      f.delta_at_keyframe.covariance.determinant() > b_T_q.covariance.determinant()) {
    tracker_.reset(core::compound(b_T_q, q_T_now));
    relocalize_ = false;
    ++stats_.delta_replaced;
  } else {
    ++stats_.delta_kept;
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
  recovery_.rejected().reset();
  if (contradicts_map) {
    // Gate recovery: two registrations agree that the robot is at b, against the map and Δ.
    // The closure a → b would carry Δ's error into the map: b becomes active, no constraint
    // (as a new session is placed on the map).
    relocalizeOn(b, b_T_q, q_T_now);
    return;
  }
  // A new pair needs saturated_closure_information unless one of its nodes takes it freely
  // (MapperOptions::closure_partners, closure_partner_sessions).
  const bool saturated =
      !known_pair && o_.closure_partners > 0 && !takesFreePair(f.active) && !takesFreePair(b);
  if (saturated && information < o_.saturated_closure_information) {
    // The map already holds what this closure says about the pair: re-localised on b, no
    // factor (MapperOptions::closure_partners).
    ++stats_.closures_saturated;
    relocalizeOn(b, b_T_q, q_T_now);
    return;
  }
  const size_t rejected_before = constraints_.rejected();
  // The chain active → keyframe → b, compounded (eq. 6-7): a constraint between existing nodes.
  addConstraint(f.active, b, a_T_b, ConstraintKind::kLoop, f.keyframe_utime, o_.map_gate > 0);
  if (constraints_.rejected() != static_cast<int64_t>(rejected_before)) {
    *registered = false;  // an inconsistent closure: neither the map nor Δ trusts it
    return;
  }
  ++stats_.loop_closures;
  active_ = b;
  tracker_.reset(core::compound(b_T_q, q_T_now));
  // Δ now reuses the registration the constraint holds: re-localise at the next chance.
  relocalize_ = true;
}

bool Mapper::takesFreePair(int64_t node) const {
  if (constraints_.partners(node) >= o_.closure_partners) return false;
  return o_.closure_partner_sessions == 0 ||
         session_ - nodes_[static_cast<size_t>(node)].session < o_.closure_partner_sessions;
}

void Mapper::relocalizeOn(int64_t b, const core::UncertainPose& b_T_q,
                          const core::UncertainPose& q_T_now) {
  active_ = b;
  tracker_.reset(core::compound(b_T_q, q_T_now));
  relocalize_ = false;
}

}  // namespace evermap::mapper
