#include "mapper-proc/gate_recovery.h"

#include "core/common/clocks.h"

namespace evermap::mapper {

std::optional<core::UncertainPose> chainPlacements(const PlacementCandidate& c,
                                                   const core::UncertainPose& b_T_q,
                                                   int64_t keyframe_utime, const Tracker& tracker) {
  const auto c_T_now = tracker.sinceKeyframe(c.keyframe_utime);
  const auto q_T_now = tracker.sinceKeyframe(keyframe_utime);
  if (!c_T_now || !q_T_now) return std::nullopt;
  // c.node_T_b = c.node_T_kc ⊕ kc_T_q ⊕ ⊖(b_T_q).
  const core::UncertainPose kc_T_q = core::compound(*c_T_now, core::invert(*q_T_now));
  return core::compound(core::compound(c.node_T_keyframe, kc_T_q), core::invert(b_T_q));
}

int64_t bridgedGaps(const TrackerCounts& c, int64_t rides) {
  return c.wheel_applied + c.restarts + c.reanchored + c.relinks_refused + c.relinks_weaker + rides;
}

void GateRecovery::confirmed(int64_t keyframe_utime, int64_t bridges, double odometer_m) {
  last_confirmed_utime_ = keyframe_utime;
  bridges_at_confirmation_ = bridges;
  odometer_at_confirmation_ = odometer_m;
}

bool GateRecovery::allowed(int64_t keyframe_utime, int64_t bridges) const {
  // Odometry bridged a gap since the last registration that confirmed it, or registrations
  // have stopped confirming it for recovery_quiet_s.
  return last_confirmed_utime_ < 0 || bridges != bridges_at_confirmation_ ||
         keyframe_utime - last_confirmed_utime_ >= micros(quiet_s_);
}

double GateRecovery::driftM(double odometer_m) const {
  return slack_m_ + drift_fraction_ * (odometer_m - odometer_at_confirmation_);
}

}  // namespace evermap::mapper
