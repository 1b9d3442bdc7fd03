#include "mapper-proc/gate_recovery.h"

#include "core/common/clocks.h"

namespace evermap::mapper {

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
