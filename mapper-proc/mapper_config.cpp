#include "mapper-proc/mapper_config.h"

#include <string>
#include <tuple>

#include "core/solver/batch_solver.h"

namespace evermap::mapper {

Status readMapperOptions(const KeyValueFile& file, MapperOptions* o) {
  KeyValueReader reader(file);
  reader.read("mapper.cell_size_m", &o->cell_size_m);
  reader.read("mapper.heading_bins", &o->heading_bins);
  reader.read("mapper.overlap_radius_cells", &o->overlap_radius_cells);
  reader.read("mapper.overlap_heading_sectors", &o->overlap_heading_sectors);
  reader.read("mapper.relocalization_checks", &o->relocalization_checks);
  reader.read("mapper.step_interval_s", &o->step_interval_s);
  reader.read("mapper.request_timeout_s", &o->request_timeout_s);
  reader.read("mapper.session_gap_s", &o->session_gap_s);
  reader.read("mapper.consistency_gate", &o->consistency_gate);
  reader.read("mapper.recent_exclusion_s", &o->recent_exclusion_s);
  reader.read("mapper.covariance_floor", &o->covariance_floor);
  reader.read("mapper.origin_sigma_m", &o->origin_sigma_m);
  reader.read("mapper.origin_sigma_rad", &o->origin_sigma_rad);
  reader.read("mapper.attitude_factors", &o->attitude_factors);
  reader.read("mapper.height_factors", &o->height_factors);
  reader.read("mapper.map_gate", &o->map_gate);
  reader.read("mapper.closure_partners", &o->closure_partners);
  reader.read("mapper.saturated_closure_information", &o->saturated_closure_information);
  reader.read("mapper.defer_merges", &o->defer_merges);
  reader.read("mapper.cell_refresh_per_step", &o->cell_refresh_per_step);
  reader.read("mapper.fuse_active_registration", &o->fuse_active_registration);
  reader.read("mapper.recovery_quiet_s", &o->recovery_quiet_s);
  reader.read("mapper.recovery_slack_m", &o->recovery_slack_m);
  reader.read("mapper.recovery_drift_fraction", &o->recovery_drift_fraction);
  reader.read("mapper.floor_match_m", &o->floor_match_m);
  reader.read("mapper.warm_restart_max_gap_s", &o->warm_restart_max_gap_s);
  reader.read("mapper.warm_restart_speed_m_s", &o->warm_restart_speed_m_s);
  reader.read("mapper.warm_restart_turn_rad_s", &o->warm_restart_turn_rad_s);
  reader.read("mapper.warm_restart_node_sigma_m", &o->warm_restart_node_sigma_m);
  reader.read("mapper.floor_gate.max_height_m", &o->floor_gate.max_height_m);
  reader.read("mapper.floor_gate.max_vertical_speed_m_s", &o->floor_gate.max_vertical_speed_m_s);
  reader.read("mapper.warm_restart_bridge", &o->warm_restart_bridge);
  reader.read("mapper.warm_restart_bridge_max_gap_s", &o->warm_restart_bridge_max_gap_s);
  reader.read("mapper.warm_restart_wheel_wait_s", &o->warm_restart_wheel_wait_s);
  reader.read("mapper.warm_restart_elevator_radius_m", &o->warm_restart_elevator_radius_m);
  reader.read("mapper.warm_restart_ride_min_s", &o->warm_restart_ride_min_s);
  reader.read("mapper.tracker.wheel_offplane_sigma_m", &o->tracker.wheel_offplane_sigma_m);
  reader.read("mapper.tracker.wheel_offplane_sigma_rad", &o->tracker.wheel_offplane_sigma_rad);
  reader.read("mapper.tracker.history_s", &o->tracker.history_s);
  reader.read("mapper.tracker.vo_timeout_s", &o->tracker.vo_timeout_s);
  reader.read("mapper.tracker.wheel_buffer_s", &o->tracker.wheel_buffer_s);
  reader.read("mapper.tracker.relink_gate", &o->tracker.relink_gate);
  reader.read("mapper.tracker.gyro_heading", &o->tracker.gyro_heading);
  reader.read("mapper.tracker.gyro_noise_density", &o->tracker.gyro_noise_density);
  reader.read("mapper.tracker.gyro_bias_correlation_s", &o->tracker.gyro_bias_correlation_s);
  reader.read("mapper.tracker.vo_gyro_gate", &o->tracker.vo_gyro_gate);
  reader.read("mapper.tracker.heading_extrapolation_rate_sigma_rad_s",
              &o->tracker.heading_extrapolation_rate_sigma_rad_s);
  reader.read("mapper.tracker.heading_extrapolation_s", &o->tracker.heading_extrapolation_s);
  reader.read("mapper.tracker.heading_wait_s", &o->tracker.heading_wait_s);
  reader.read("mapper.tracker.max_speed_m_s", &o->tracker.max_speed_m_s);
  reader.read("mapper.tracker.max_turn_rad_s", &o->tracker.max_turn_rad_s);
  std::string method;
  reader.read("mapper.solver.method", &method);
  reader.read("mapper.solver.batch_every", &o->solver.batch_every);
  reader.read("mapper.solver.wildfire_threshold", &o->solver.wildfire_threshold);
  reader.read("mapper.solver.initial_trust_radius", &o->solver.initial_trust_radius);
  reader.read("mapper.solver.recent_last", &o->solver.recent_last);
  reader.read("mapper.solver.background_batch_lag", &o->solver.background_batch_lag);
  std::string loop_kernel, vetted_loop_kernel;
  reader.read("mapper.loop_kernel", &loop_kernel);
  reader.read("mapper.vetted_loop_kernel", &vetted_loop_kernel);
  if (auto s = reader.finish(); !s) return s;
  for (auto [key, text, kernel] :
       {std::tuple{"mapper.loop_kernel", &loop_kernel, &o->loop_kernel},
        std::tuple{"mapper.vetted_loop_kernel", &vetted_loop_kernel, &o->vetted_loop_kernel}}) {
    if (text->empty()) continue;
    auto k = solver::parseRobustKernel(*text);
    if (!k) return makeError(reader.where(key), ": ", key, ": ", k.error().message);
    *kernel = *k;
  }
  if (!method.empty()) {
    auto m = solver::parseMethod(method);
    if (!m || *m == solver::Method::kLevenbergMarquardt)
      return makeError(reader.where("mapper.solver.method"),
                       ": mapper.solver.method: expected 'gn' or 'dogleg', got '", method, "'");
    o->solver.method = *m;
  }
  if (auto s = o->validate(); !s) return makeError(file.name(), ": ", s.error().message);
  return Ok{};
}

}  // namespace evermap::mapper
