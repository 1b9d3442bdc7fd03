#pragma once
// Placements that wait for a second registration to agree, and when the map gate may be
// overridden (mapper.h, "gate recovery"). A registration the gate rejects says either that
// it is a false match or that the map's idea of where the robot is (Δ, or the chain of nodes
// made since the last closure) went wrong; two rejected registrations that agree through
// odometry tell the two apart. Repeated texture makes false matches that agree with each
// other, so a recovery overrides Δ only when odometry bridged a gap since the last
// registration that confirmed Δ (or none has for recovery_quiet_s), and only by a jump
// odometry could have drifted since (recovery_slack_m + recovery_drift_fraction × the
// distance travelled).

#include <cstdint>
#include <optional>

#include "core/geometry/se3.h"
#include "mapper-proc/mapper_options.h"

namespace evermap::mapper {

// A registration that places the robot (node_T_keyframe), waiting for a second one that
// agrees with it through odometry.
struct PlacementCandidate {
  int64_t node;
  core::UncertainPose node_T_keyframe;
  int64_t keyframe_utime;
  int verifications = 0;  // node-mode requests sent to check it (Mapper::step)
};

// Two placements of the robot chained through odometry (eq. 6-7): c.node_T_b measured by the
// candidate c and the registration b_T_q of the keyframe at keyframe_utime, the motion
// between the two keyframes from the tracker's history (its covariance counted twice where
// the two chains share increments: a looser test). Empty when a keyframe is no longer in the
// history. Used by the mapper (relocalisation, gate recovery) and the localizer alike.
std::optional<core::UncertainPose> chainPlacements(const PlacementCandidate& c,
                                                   const core::UncertainPose& b_T_q,
                                                   int64_t keyframe_utime, const Tracker& tracker);

// The gaps odometry has bridged so far (GateRecovery::allowed): the tracker's wheel increments,
// VO restarts, re-anchorings and refused relinks, and the elevator rides.
int64_t bridgedGaps(const TrackerCounts& c, int64_t rides);

class GateRecovery {
 public:
  explicit GateRecovery(const MapperOptions& o)
      : quiet_s_(o.recovery_quiet_s),
        slack_m_(o.recovery_slack_m),
        drift_fraction_(o.recovery_drift_fraction) {}

  // A registration the step accepted at keyframe_utime, with the gaps odometry had bridged
  // (`bridges`) and the distance travelled then.
  void confirmed(int64_t keyframe_utime, int64_t bridges, double odometer_m);
  // Whether a recovery may override Δ at keyframe_utime, `bridges` bridged by now.
  bool allowed(int64_t keyframe_utime, int64_t bridges) const;
  // The largest jump odometry could have made since the last confirmed registration, at
  // odometer_m travelled.
  double driftM(double odometer_m) const;
  // The last registration the gate rejected, waiting for a second one that agrees.
  std::optional<PlacementCandidate>& rejected() { return rejected_; }
  // A registration the gate rejects now (`refused`, a jump of jump_m from where Δ has the
  // robot): whether it overrides Δ. It does when it agrees with the last one rejected
  // (`agrees(last)`, asked only while a recovery is allowed: `bridges` bridged by now) and
  // jump_m is at most driftM(odometer_m); then none waits any more. Otherwise it waits in the
  // last one's place; *too_far says it agreed but jumped farther.
  template <class Agrees>
  bool overrides(const PlacementCandidate& refused, int64_t bridges, double jump_m,
                 double odometer_m, Agrees&& agrees, bool* too_far) {
    const bool agree = rejected_ && allowed(refused.keyframe_utime, bridges) && agrees(*rejected_);
    *too_far = agree && jump_m > driftM(odometer_m);
    if (agree && !*too_far) {
      rejected_.reset();
      return true;
    }
    rejected_ = refused;
    return false;
  }

 private:
  double quiet_s_;
  double slack_m_;
  double drift_fraction_;
  std::optional<PlacementCandidate> rejected_;
  int64_t last_confirmed_utime_ = -1;  // keyframe of the last accepted registration
  int64_t bridges_at_confirmation_ = 0;
  double odometer_at_confirmation_ = 0.0;
};

}  // namespace evermap::mapper
