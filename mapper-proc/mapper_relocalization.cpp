// Placing the robot on the map by registrations that agree (mapper.h): a lost session's
// relocalisation (its candidate placement checked where it predicts the robot is, and on the
// same keyframe against a linked node), a warm restart's confirmation, and the gate recovery
// (two rejected registrations that agree override Δ; gate_recovery.h).

#include <cmath>
#include <limits>

#include "core/common/clocks.h"
#include "mapper-proc/mapper.h"

namespace evermap::mapper {

bool Mapper::confirmsCandidate(const InFlight& f, int64_t b, const core::UncertainPose& b_T_q,
                               std::optional<int64_t>* check) {
  if (confirmsRelocalization(b, b_T_q, f.keyframe_utime, relocalization_candidate_)) {
    relocalization_candidate_.reset();
    return true;
  }
  relocalization_candidate_ = PlacementCandidate{b, b_T_q, f.keyframe_utime};
  // The check that needs no motion: the same keyframe against a node the map links to b,
  // where that placement says it is seen. Without it the first check waited for the next
  // keyframe, which a robot starting slowly makes seconds later, often past the place.
  if (!f.same_frame_check && o_.relocalization_checks > 0)
    *check = linkedNeighbour(b, nodePose(b) * b_T_q.mean);
  return false;
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
  // Agreeing registrations one texture period away: not a drift odometry could have made.
  bool too_far = false;
  const bool agree = recovery_.overrides(
      PlacementCandidate{b, b_T_q, keyframe_utime}, bridges(), jump_m, tracker_.odometerM(),
      [&](const PlacementCandidate& last) {
        return confirmsRelocalization(b, b_T_q, keyframe_utime, last);
      },
      &too_far);
  if (too_far) ++stats_.recoveries_too_far;
  if (agree) ++stats_.gate_recoveries;
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
  PlacementCandidate& c = *relocalization_candidate_;
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
                                    const std::optional<PlacementCandidate>& candidate) {
  if (!candidate) return false;
  const PlacementCandidate c = *candidate;
  // The two placements chained (gate_recovery.h); too old: the newer one becomes the candidate.
  const auto chained = chainPlacements(c, b_T_q, keyframe_utime, tracker_);
  if (!chained) return false;
  const core::UncertainPose& measured = *chained;
  bool agree = false;
  if (c.node == b) {
    agree = map_gate_.agree(core::UncertainPose{}, measured);
  } else {
    agree = consistentWithMap(c.node, b, measured);
  }
  if (!agree) ++stats_.relocalization_disagreements;
  return agree;
}

int64_t Mapper::bridges() const { return bridgedGaps(tracker_.counts(), floors_.rides()); }

bool Mapper::consistentWithMap(int64_t a, int64_t b, const core::UncertainPose& a_T_b,
                               double* information) {
  return map_gate_.consistent(schedule_, a, b, a_T_b, information, &stats_.timing.registration_s);
}

}  // namespace evermap::mapper
