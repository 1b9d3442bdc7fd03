// The localizer's registrations (localizer.h): an answer corrects a localized pose when the
// map gate lets it, or places a robot that is not localized when a second one agrees with it.

#include <cmath>
#include <numbers>

#include "core/messages/pose_fields.h"
#include "mapper-proc/constraint_set.h"
#include "mapper-proc/localizer.h"

namespace evermap::mapper {

Status Localizer::onRegisterResult(const register_result_t& msg) {
  if (!in_flight_ || msg.request_id != in_flight_->request_id ||
      msg.keyframe_utime != in_flight_->keyframe_utime) {
    ++stats_.dropped;
    return makeError("REGISTER_RESULT ", msg.request_id, ": no such request in flight");
  }
  const InFlight f = *in_flight_;
  if (msg.status != register_result_t::STATUS_OK) {
    // The node of the place did not register: the floor's global search, once.
    if (f.mode == register_request_t::MODE_NODE && f.localized) {
      sendRequest(register_request_t::MODE_GLOBAL, -1);
    } else {
      in_flight_.reset();
    }
    return Ok{};
  }
  in_flight_.reset();
  const bool pose_ok =
      messages::poseFromMessage(msg.translation, msg.orientation, "REGISTER_RESULT").ok();
  const auto cam_cov = messages::covarianceFromMessage(msg.covariance, "REGISTER_RESULT");
  const int64_t b = msg.node_id;
  if (!pose_ok || !cam_cov || b < 0 || b >= static_cast<int64_t>(nodes_.size())) {
    ++stats_.dropped;
    return makeError("REGISTER_RESULT ", msg.request_id, ": malformed pose, covariance or node id");
  }
  ++stats_.registrations_ok;
  if (otherFloor(b)) {
    ++stats_.refused_floor;  // the elevator cab, or a floor that looks like this one
    return Ok{};
  }
  const Eigen::Quaterniond q = *messages::quaternionFromMessage(msg.orientation, "REGISTER_RESULT");
  const core::SE3d cam_T(q.normalized(),
                         core::Vec3(msg.translation[0], msg.translation[1], msg.translation[2]));
  // The registration in body frames (paper eq. 9), by STEREO_CALIB's mounting.
  const core::UncertainPose b_T_q = tracker_.registrationToBody(cam_T, *cam_cov);
  const auto q_T_now = tracker_.sinceKeyframe(f.keyframe_utime);
  if (!q_T_now) {
    ++stats_.dropped;
    return Ok{};
  }
  if (localized_ && f.localized && f.active == active_) {
    correct(f, b, b_T_q, *q_T_now);
  } else {
    place(f, b, b_T_q, *q_T_now);
  }
  return Ok{};
}

bool Localizer::otherFloor(int64_t b) const {
  if (localized_ && floor_ >= 0) return nodes_[static_cast<size_t>(b)].floor != floor_;
  // Placed once, the height is known (the rides measured it) even where the floor is not a
  // stored one: the floors of a building look alike, and a node at another height is one.
  return placed() &&
         std::abs(nodePose(b).translation().z() - pose().mean.translation().z()) > o_.floor_match_m;
}

void Localizer::correct(const InFlight& f, int64_t b, const core::UncertainPose& b_T_q,
                        const core::UncertainPose& q_T_now) {
  // The prediction of b_T_q: the stored poses (known) and Δ at the keyframe (its covariance).
  const core::UncertainPose b_T_a{nodePose(b).inverse() * nodePose(f.active), core::Mat6::Zero()};
  const core::UncertainPose predicted = core::compound(b_T_a, f.delta_at_keyframe);
  if (!map_gate_.agree(predicted, b_T_q)) {
    ++stats_.refused_gate;  // counted, never applied alone
    recover(f, b, b_T_q, q_T_now);
    return;
  }
  // Two independent measurements of b_T_q: their information-weighted fusion.
  trackFrom(b, core::compound(ConstraintSet::fuse(predicted, b_T_q), q_T_now), f.keyframe_utime);
  recovery_.rejected().reset();
  ++stats_.corrections;
}

bool Localizer::recover(const InFlight& f, int64_t b, const core::UncertainPose& b_T_q,
                        const core::UncertainPose& q_T_now) {
  bool too_far = false;  // one texture period away: not a drift
  const bool agree = recovery_.overrides(
      PlacementCandidate{b, b_T_q, f.keyframe_utime}, bridgedGaps(tracker_.counts(), stats_.rides),
      jumpM(f, b, b_T_q), tracker_.odometerM(),
      [&](const PlacementCandidate& last) { return agrees(last, b, b_T_q, f.keyframe_utime); },
      &too_far);
  if (too_far) ++stats_.recoveries_too_far;
  if (!agree) return false;
  trackFrom(b, core::compound(b_T_q, q_T_now), f.keyframe_utime);
  ++stats_.gate_recoveries;
  return true;
}

double Localizer::jumpM(const InFlight& f, int64_t b, const core::UncertainPose& b_T_q) const {
  const core::SE3d tracked = nodePose(f.active) * f.delta_at_keyframe.mean;
  return (tracked.translation() - (nodePose(b) * b_T_q.mean).translation()).norm();
}

void Localizer::place(const InFlight& f, int64_t b, const core::UncertainPose& b_T_q,
                      const core::UncertainPose& q_T_now) {
  // One match may be a false one: the robot is placed only when two registrations, chained by
  // odometry, agree on where it is.
  if (!candidate_ || !agrees(*candidate_, b, b_T_q, f.keyframe_utime)) {
    candidate_ = PlacementCandidate{b, b_T_q, f.keyframe_utime};
    return;
  }
  candidate_.reset();
  // Placed before, the dead-reckoned pose still bounds where the robot can be.
  if (f.active >= 0 && jumpM(f, b, b_T_q) > recovery_.driftM(tracker_.odometerM())) {
    ++stats_.placements_too_far;
    return;
  }
  floor_ = nodes_[static_cast<size_t>(b)].floor;
  trackFrom(b, core::compound(b_T_q, q_T_now), f.keyframe_utime);
  localized_ = true;
  ++stats_.placements;
  updateLocalized();  // a placement too uncertain for the bounds is not localized
}

bool Localizer::agrees(const PlacementCandidate& c, int64_t b, const core::UncertainPose& b_T_q,
                       int64_t keyframe_utime) {
  const auto measured = chainPlacements(c, b_T_q, keyframe_utime, tracker_);
  if (!measured) return false;
  // The map's c_T_b, its stored poses' relative uncertainty given localize.map_sigma_*.
  core::Vec6 sigma;
  const double m = o_.localize.map_sigma_m;
  const double r = o_.localize.map_sigma_deg * std::numbers::pi / 180.0;
  sigma << m, m, m, r, r, r;
  const core::UncertainPose map_c_T_b{nodePose(c.node).inverse() * nodePose(b),
                                      sigma.cwiseAbs2().asDiagonal()};
  const bool agree = map_gate_.agree(map_c_T_b, *measured);
  if (!agree) ++stats_.disagreements;
  return agree;
}

void Localizer::trackFrom(int64_t b, const core::UncertainPose& b_T_now, int64_t keyframe_utime) {
  active_ = b;
  tracker_.reset(b_T_now);
  odometer_at_fix_m_ = tracker_.odometerM();
  // A registration applied confirms the pose (gate_recovery.h).
  recovery_.confirmed(keyframe_utime, bridgedGaps(tracker_.counts(), stats_.rides),
                      odometer_at_fix_m_);
}

}  // namespace evermap::mapper
