// ElevatorTrackerOptions' rules between fields and the counts' summary line
// (elevator_tracker.h).
#include <cstdio>

#include "elevator-proc/elevator_tracker.h"

namespace evermap::elevator {

// Single-field ranges are declared (elevator_tracker.h); these are the rules between fields.
Status ElevatorTrackerOptions::validate() const {
  if (Status st = pulse.validate(); !st.ok()) return st;
  if (Status st = floors.validate(); !st.ok()) return st;
  if (Status st = gate.validate(); !st.ok()) return st;
  if (Status st = checkOptionRanges(*this); !st.ok()) return st;
  if (!(gravity_min_calm_s <= gravity_window_s)) {
    return makeError("need gravity_min_calm_s <= gravity_window_s");
  }
  if (!(gravity_provisional_calm_s <= gravity_min_calm_s)) {
    return makeError("need gravity_provisional_calm_s <= gravity_min_calm_s");
  }
  if (!(motion_window_s >= 2 * pulse.bin_s)) {
    return makeError("motion_window_s must be at least two bins");
  }
  if (!(lowpass_width_s >= 4 * pulse.bin_s) || !(step_window_s >= 2 * pulse.bin_s)) {
    return makeError("lowpass_width_s must be >= 4 and step_window_s >= 2 pulse bins");
  }
  if (!(walking_step_off_m_s2 <= walking_step_on_m_s2)) {
    return makeError("need walking_step_off_m_s2 <= walking_step_on_m_s2");
  }
  if (!(max_fill_s <= max_gap_in_ride_s)) {
    return makeError("need max_fill_s <= max_gap_in_ride_s");
  }
  if (!(max_gap_in_ride_s >= pulse.bin_s))
    return makeError("max_gap_in_ride_s must be >= pulse_bin_s");
  return Ok{};
}

std::string ElevatorCounts::summary() const {
  char buf[256];
  std::snprintf(
      buf, sizeof buf,
      "samples used %lld, without attitude %lld, bins %lld (empty %lld, filled %lld), pulses %lld, "
      "rides %lld, abandoned %lld, rejected %lld, vertical alarms %lld",
      static_cast<long long>(samples_used), static_cast<long long>(no_attitude),
      static_cast<long long>(bins), static_cast<long long>(empty_bins),
      static_cast<long long>(filled_bins), static_cast<long long>(pulses),
      static_cast<long long>(rides), static_cast<long long>(abandoned),
      static_cast<long long>(rejected), static_cast<long long>(vertical_alarms));
  return buf;
}

}  // namespace evermap::elevator
