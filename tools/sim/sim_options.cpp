#include "tools/sim/sim_options.h"

#include <charconv>
#include <sstream>

namespace evermap::sim {
namespace {

// The one table of keys: calls v(key, &field) for every setting, in file order.
template <typename Options, typename Visitor>
void visitOptions(Options& o, Visitor&& v) {
  v("seed", &o.seed);
  auto& b = o.building;
  v("building.floors", &b.floors);
  v("building.main_floor", &b.main_floor);
  v("building.storey_height_m", &b.storey_height_m);
  v("building.storey_jitter_m", &b.storey_jitter_m);
  v("building.corridor_half_width_m", &b.corridor_half_width_m);
  v("building.cross_corridor_spacing_m", &b.cross_corridor_spacing_m);
  v("building.long_corridor_spacing_m", &b.long_corridor_spacing_m);
  v("building.main_cross_corridors", &b.main_cross_corridors);
  v("building.main_long_corridors", &b.main_long_corridors);
  v("building.min_cross_corridors", &b.min_cross_corridors);
  v("building.max_cross_corridors", &b.max_cross_corridors);
  v("building.max_long_corridors", &b.max_long_corridors);
  v("building.room_width_m", &b.room_width_m);
  v("building.room_depth_m", &b.room_depth_m);
  v("building.room_probability", &b.room_probability);
  v("building.dark_room_fraction", &b.dark_room_fraction);
  v("building.blank_wall_fraction", &b.blank_wall_fraction);
  v("building.cab_width_m", &b.cab_width_m);
  v("building.cab_depth_m", &b.cab_depth_m);
  auto& p = o.patrol;
  v("patrol.sessions", &p.sessions);
  v("patrol.total_hours", &p.total_hours);
  v("patrol.session_jitter", &p.session_jitter);
  v("patrol.span_days", &p.span_days);
  v("patrol.start_utime", &p.start_utime);
  v("patrol.drive_speed_mps", &p.drive_speed_mps);
  v("patrol.drive_accel_mps2", &p.drive_accel_mps2);
  v("patrol.turn_rate_radps", &p.turn_rate_radps);
  v("patrol.turn_accel_radps2", &p.turn_accel_radps2);
  v("patrol.pause_min_s", &p.pause_min_s);
  v("patrol.pause_max_s", &p.pause_max_s);
  v("patrol.goals_min", &p.goals_min);
  v("patrol.goals_max", &p.goals_max);
  v("patrol.other_floor_probability", &p.other_floor_probability);
  v("patrol.explore_sessions", &p.explore_sessions);
  v("patrol.explore_tours", &p.explore_tours);
  v("patrol.roughness_rad", &p.roughness_rad);
  auto& e = o.elevator;
  v("elevator.accel_min_mps2", &e.accel_min_mps2);
  v("elevator.accel_max_mps2", &e.accel_max_mps2);
  v("elevator.speed_min_mps", &e.speed_min_mps);
  v("elevator.speed_max_mps", &e.speed_max_mps);
  v("elevator.call_wait_max_s", &e.call_wait_max_s);
  v("elevator.door_wait_min_s", &e.door_wait_min_s);
  v("elevator.door_wait_max_s", &e.door_wait_max_s);
  v("elevator.intermediate_stop_probability", &e.intermediate_stop_probability);
  v("elevator.stop_dwell_min_s", &e.stop_dwell_min_s);
  v("elevator.stop_dwell_max_s", &e.stop_dwell_max_s);
  auto& s = o.sensors;
  v("camera.height_m", &s.camera.height_m);
  v("camera.forward_m", &s.camera.forward_m);
  v("camera.fx", &s.camera.fx);
  v("camera.fy", &s.camera.fy);
  v("camera.cx", &s.camera.cx);
  v("camera.cy", &s.camera.cy);
  v("camera.baseline_m", &s.camera.baseline_m);
  v("vo.rate_hz", &s.vo.rate_hz);
  v("vo.keyframe_translation_m", &s.vo.keyframe_translation_m);
  v("vo.keyframe_rotation_rad", &s.vo.keyframe_rotation_rad);
  v("vo.translation_sigma_m", &s.vo.translation_sigma_m);
  v("vo.translation_sigma_per_m", &s.vo.translation_sigma_per_m);
  v("vo.translation_sigma_per_rad", &s.vo.translation_sigma_per_rad);
  v("vo.rotation_sigma_rad", &s.vo.rotation_sigma_rad);
  v("vo.rotation_sigma_per_rad", &s.vo.rotation_sigma_per_rad);
  v("vo.rotation_sigma_per_m", &s.vo.rotation_sigma_per_m);
  v("vo.fail_in_dark_rooms", &s.vo.fail_in_dark_rooms);
  v("vo.fail_at_blank_walls", &s.vo.fail_at_blank_walls);
  v("vo.fail_in_elevator", &s.vo.fail_in_elevator);
  v("vo.passerby_rate_per_hour", &s.vo.passerby_rate_per_hour);
  v("vo.passerby_min_s", &s.vo.passerby_min_s);
  v("vo.passerby_max_s", &s.vo.passerby_max_s);
  v("wheel.rate_hz", &s.wheel.rate_hz);
  v("wheel.sigma_m", &s.wheel.sigma_m);
  v("wheel.sigma_rad", &s.wheel.sigma_rad);
  v("wheel.sigma_forward_per_m", &s.wheel.sigma_forward_per_m);
  v("wheel.sigma_lateral_per_m", &s.wheel.sigma_lateral_per_m);
  v("wheel.sigma_theta_per_m", &s.wheel.sigma_theta_per_m);
  v("wheel.sigma_theta_per_rad", &s.wheel.sigma_theta_per_rad);
  v("wheel.slip_rate_per_hour", &s.wheel.slip_rate_per_hour);
  v("wheel.slip_min_s", &s.wheel.slip_min_s);
  v("wheel.slip_max_s", &s.wheel.slip_max_s);
  v("wheel.slip_min_fraction", &s.wheel.slip_min_fraction);
  v("wheel.slip_max_fraction", &s.wheel.slip_max_fraction);
  v("wheel.slip_yaw_rad_per_m", &s.wheel.slip_yaw_rad_per_m);
  v("attitude.rate_hz", &s.attitude.rate_hz);
  v("attitude.sigma_rad", &s.attitude.sigma_rad);
  v("attitude.untrusted_accel_mps2", &s.attitude.untrusted_accel_mps2);
  v("attitude.heading", &s.attitude.heading);
  v("attitude.heading_noise_density", &s.attitude.heading_noise_density);
  v("attitude.heading_bias_sigma_rad_s", &s.attitude.heading_bias_sigma_rad_s);
  v("attitude.heading_bias_walk_density", &s.attitude.heading_bias_walk_density);
  v("attitude.heading_scale_sigma", &s.attitude.heading_scale_sigma);
  v("attitude.heading_still_s", &s.attitude.heading_still_s);
  v("floor.height_sigma_m", &s.floor.height_sigma_m);
  v("floor.height_sigma_per_m", &s.floor.height_sigma_per_m);
  v("floor.match_threshold_m", &s.floor.match_threshold_m);
  v("imu.enabled", &s.imu.enabled);
  v("imu.rate_hz", &s.imu.rate_hz);
  v("imu.margin_s", &s.imu.margin_s);
  v("imu.accel_sigma_mps2", &s.imu.accel_sigma_mps2);
  v("imu.gyro_sigma_radps", &s.imu.gyro_sigma_radps);
  v("imu.gyro_bias_sigma_radps", &s.imu.gyro_bias_sigma_radps);
  v("imu.accel_bias_sigma_mps2", &s.imu.accel_bias_sigma_mps2);
  v("imu.gravity_mps2", &s.imu.gravity_mps2);
  v("ground_truth.rate_hz", &s.ground_truth_rate_hz);
  auto& r = o.oracle;
  v("oracle.max_distance_m", &r.max_distance_m);
  v("oracle.max_view_angle_rad", &r.max_view_angle_rad);
  v("oracle.success_probability", &r.success_probability);
  v("oracle.distance_scale_m", &r.distance_scale_m);
  v("oracle.angle_scale_rad", &r.angle_scale_rad);
  v("oracle.global_candidates", &r.global_candidates);
  v("oracle.false_match_rate_node", &r.false_match_rate_node);
  v("oracle.false_match_rate_global", &r.false_match_rate_global);
  v("oracle.translation_sigma_m", &r.translation_sigma_m);
  v("oracle.translation_sigma_per_m", &r.translation_sigma_per_m);
  v("oracle.rotation_sigma_rad", &r.rotation_sigma_rad);
  v("oracle.rotation_sigma_per_rad", &r.rotation_sigma_per_rad);
  v("oracle.min_inliers", &r.min_inliers);
  v("oracle.max_inliers", &r.max_inliers);
  v("oracle.keyframe_window_s", &r.keyframe_window_s);
  v("trajectory.file", &o.trajectory.file);
  v("trajectory.rate_hz", &o.trajectory.rate_hz);
  v("trajectory.first", &o.trajectory.first);
  v("trajectory.count", &o.trajectory.count);
  v("output.split_sessions", &o.output.split_sessions);
  v("output.tum", &o.output.tum);
}

std::string format(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);  // shortest exact round trip
  return std::string(buf, r.ptr);
}
std::string format(int v) { return std::to_string(v); }
std::string format(int64_t v) { return std::to_string(v); }
std::string format(uint64_t v) { return std::to_string(v); }
std::string format(bool v) { return v ? "true" : "false"; }
std::string format(const std::string& v) { return v; }

}  // namespace

Status TrajectoryOptions::validate() const {
  if (file.empty()) return makeError("trajectory.file: needed with mode = trajectory");
  if (!(rate_hz > 0.0)) return makeError("trajectory.rate_hz: must be > 0");
  if (first < 0) return makeError("trajectory.first: must be >= 0");
  if (count < 0 || count == 1) return makeError("trajectory.count: must be 0 (all) or >= 2");
  return Ok{};
}

Status SimOptions::validate() const {
  const std::pair<const char*, Status> parts[] = {{"building.", building.validate()},
                                                  {"patrol.", patrol.validate()},
                                                  {"elevator.", elevator.validate()},
                                                  {"oracle.", oracle.validate()}};
  for (const auto& [prefix, status] : parts) {
    if (!status) return makeError(prefix, status.error().message);
  }
  if (auto s = sensors.validate(); !s) return s;
  if (mode == Mode::kTrajectory) {
    if (auto s = trajectory.validate(); !s) return s;
  }
  return Ok{};
}

std::string SimOptions::toConfigText() const {
  std::ostringstream out;
  out << "mode = " << (mode == Mode::kBuilding ? "building" : "trajectory") << "\n";
  SimOptions copy = *this;
  visitOptions(copy, [&](const char* key, auto* field) {
    const std::string value = format(*field);
    // An empty value cannot be written as `key = value`: leave the default in place.
    if (value.empty())
      out << "# " << key << " = (empty)\n";
    else
      out << key << " = " << value << "\n";
  });
  return out.str();
}

Expected<SimOptions> loadSimOptions(const KeyValueFile& file) {
  SimOptions o;
  KeyValueReader reader(file);
  std::string mode = "building";
  reader.read("mode", &mode);
  if (mode == "trajectory") {
    o.mode = SimOptions::Mode::kTrajectory;
  } else if (mode != "building") {
    return makeError(reader.where("mode"), ": mode: expected 'building' or 'trajectory', got '",
                     mode, "'");
  }
  visitOptions(o, [&](const char* key, auto* field) { reader.read(key, field); });
  // meta.*: what the simulator wrote about a run; mapper.*: the mapper's options, which a
  // run's config may carry (evermap-mapper-run reads them, KeyValueFile::extract).
  if (auto s = reader.finish({"meta.", "mapper."}); !s) return s.error();
  // An empty string would make the trajectory file the config folder itself.
  if (!o.trajectory.file.empty() && std::filesystem::path(o.trajectory.file).is_relative()) {
    o.trajectory.file = (file.folder() / o.trajectory.file).lexically_normal().string();
  }
  if (auto s = o.validate(); !s) {
    const std::string& m = s.error().message;
    const std::string key = m.substr(0, m.find(':'));
    return makeError(reader.where(key), ": ", m);
  }
  return o;
}

}  // namespace evermap::sim
