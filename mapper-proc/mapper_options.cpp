#include "mapper-proc/mapper_options.h"

namespace evermap::mapper {

Status MapperOptions::validate() const {
  if (!(cell_size_m > 0.0)) return Error{"mapper.cell_size_m: must be > 0"};
  if (heading_bins < 1) return Error{"mapper.heading_bins: must be >= 1"};
  if (!(overlap_radius_cells >= 0.0 && overlap_radius_cells <= 3.0))
    return Error{"mapper.overlap_radius_cells: must be in [0, 3]"};
  if (!(overlap_heading_sectors >= 0.0 && overlap_heading_sectors <= 1.0))
    return Error{"mapper.overlap_heading_sectors: must be in [0, 1]"};
  if (relocalization_checks < 0) return Error{"mapper.relocalization_checks: must be >= 0"};
  if (!(step_interval_s >= 0.0)) return Error{"mapper.step_interval_s: must be >= 0"};
  if (!(request_timeout_s > 0.0)) return Error{"mapper.request_timeout_s: must be > 0"};
  if (!(session_gap_s > 0.0)) return Error{"mapper.session_gap_s: must be > 0"};
  if (!(recovery_quiet_s >= 0.0)) return Error{"mapper.recovery_quiet_s: must be >= 0"};
  if (!(recovery_slack_m >= 0.0)) return Error{"mapper.recovery_slack_m: must be >= 0"};
  if (!(recovery_drift_fraction >= 0.0))
    return Error{"mapper.recovery_drift_fraction: must be >= 0"};
  if (!(floor_match_m > 0.0)) return Error{"mapper.floor_match_m: must be > 0"};
  if (!(warm_restart_max_gap_s >= 0.0) || !std::isfinite(warm_restart_max_gap_s))
    return Error{"mapper.warm_restart_max_gap_s: must be a finite number >= 0"};
  if (!(warm_restart_speed_m_s > 0.0) || !std::isfinite(warm_restart_speed_m_s))
    return Error{"mapper.warm_restart_speed_m_s: must be a finite number > 0"};
  if (!(warm_restart_turn_rad_s > 0.0) || !std::isfinite(warm_restart_turn_rad_s))
    return Error{"mapper.warm_restart_turn_rad_s: must be a finite number > 0"};
  if (!(warm_restart_node_sigma_m >= 0.0))
    return Error{"mapper.warm_restart_node_sigma_m: must be >= 0"};
  if (!(warm_restart_bridge_max_gap_s >= 0.0) || !std::isfinite(warm_restart_bridge_max_gap_s))
    return Error{"mapper.warm_restart_bridge_max_gap_s: must be a finite number >= 0"};
  if (!(warm_restart_wheel_wait_s >= 0.0) || !(warm_restart_wheel_wait_s <= 10.0))
    return Error{"mapper.warm_restart_wheel_wait_s: must be a number in [0, 10]"};
  if (!(warm_restart_elevator_radius_m >= 0.0) || !std::isfinite(warm_restart_elevator_radius_m))
    return Error{"mapper.warm_restart_elevator_radius_m: must be a finite number >= 0"};
  if (!(warm_restart_ride_min_s >= 0.0) || !std::isfinite(warm_restart_ride_min_s))
    return Error{"mapper.warm_restart_ride_min_s: must be a finite number >= 0"};
  if (!(consistency_gate > 0.0)) return Error{"mapper.consistency_gate: must be > 0"};
  if (!(map_gate >= 0.0)) return Error{"mapper.map_gate: must be >= 0"};
  // 1 would test every new pair (a node has its odometry partner from the start).
  if (closure_partners < 0 || closure_partners == 1)
    return Error{"mapper.closure_partners: must be 0 (no bound) or >= 2"};
  if (!(saturated_closure_information >= 0.0) || !std::isfinite(saturated_closure_information))
    return Error{"mapper.saturated_closure_information: must be a finite number >= 0"};
  if (!(recent_exclusion_s >= 0.0)) return Error{"mapper.recent_exclusion_s: must be >= 0"};
  if (!(covariance_floor >= 0.0)) return Error{"mapper.covariance_floor: must be >= 0"};
  if (cell_refresh_per_step < 1) return Error{"mapper.cell_refresh_per_step: must be >= 1"};
  if (!(origin_sigma_m > 0.0) || !(origin_sigma_rad > 0.0))
    return Error{"mapper.origin_sigma: must be > 0"};
  if (auto s = floor_gate.validate(); !s) return s;
  if (auto s = tracker.validate(); !s) return s;
  return solver.validate();
}

}  // namespace evermap::mapper
