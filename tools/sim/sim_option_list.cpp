// The measurement-level simulator's keys (config/sim-*.conf): each declared once, with its
// unit, the values it allows on its own and one line of doc. Rules that tie keys together
// (main_floor < floors, min <= max) stay in the structs' validate().

#include "core/common/option_fields.h"
#include "tools/sim/sim_options.h"

namespace evermap::sim {
namespace {

void declareBuilding(OptionList& o, BuildingOptions& b) {
  o.add("building.floors", &b.floors, "", "floors of the building").min(1);
  o.add("building.main_floor", &b.main_floor, "", "the floor patrolled most (< floors)").min(0);
  o.add("building.storey_height_m", &b.storey_height_m, "m", "nominal floor-to-floor height")
      .positive();
  o.add("building.storey_jitter_m", &b.storey_jitter_m, "m",
        "each storey is nominal +- this (uniform; < storey_height_m / 2)")
      .min(0);
  o.add("building.corridor_half_width_m", &b.corridor_half_width_m, "m", "half a corridor's width")
      .positive();
  o.add("building.cross_corridor_spacing_m", &b.cross_corridor_spacing_m, "m",
        "between cross corridors (room for one room between them)")
      .any();
  o.add("building.long_corridor_spacing_m", &b.long_corridor_spacing_m, "m",
        "between long corridors (>= 2 (corridor_half_width_m + room_depth_m))")
      .any();
  o.add("building.main_cross_corridors", &b.main_cross_corridors, "", "cross corridors, main floor")
      .min(2);
  o.add("building.main_long_corridors", &b.main_long_corridors, "", "long corridors, main floor")
      .min(1);
  o.add("building.min_cross_corridors", &b.min_cross_corridors, "",
        "other floors: fewest cross corridors")
      .min(2);
  o.add("building.max_cross_corridors", &b.max_cross_corridors, "",
        "other floors: most cross corridors (>= min)")
      .any();
  o.add("building.max_long_corridors", &b.max_long_corridors, "",
        "other floors: long corridors drawn in [1, max]")
      .min(1);
  o.add("building.room_width_m", &b.room_width_m, "m", "along the corridor").positive();
  o.add("building.room_depth_m", &b.room_depth_m, "m", "away from the corridor").positive();
  o.add("building.room_probability", &b.room_probability, "",
        "a room in each slot along a corridor side")
      .in(0, 1);
  o.add("building.dark_room_fraction", &b.dark_room_fraction, "", "rooms with the lights off")
      .in(0, 1);
  o.add("building.blank_wall_fraction", &b.blank_wall_fraction, "",
        "junctions with featureless walls")
      .in(0, 1);
  o.add("building.cab_width_m", &b.cab_width_m, "m", "elevator cab (fits between corridors)")
      .positive();
  o.add("building.cab_depth_m", &b.cab_depth_m, "m", "elevator cab").positive();
}

void declarePatrol(OptionList& o, PatrolOptions& p) {
  o.add("patrol.sessions", &p.sessions, "", "sessions of the run").min(1);
  o.add("patrol.total_hours", &p.total_hours, "h", "operating time, summed over sessions")
      .positive();
  o.add("patrol.session_jitter", &p.session_jitter, "",
        "each session lasts mean * (1 +- jitter), then rescaled")
      .min(0)
      .below(1);
  o.add("patrol.span_days", &p.span_days, "d", "the sessions are spread over this many days")
      .min(0);
  o.add("patrol.start_utime", &p.start_utime, "us", "start of session 0 (Unix time)").min(0);
  o.add("patrol.drive_speed_mps", &p.drive_speed_mps, "m/s", "cruise speed (each leg +-15 %)")
      .positive();
  o.add("patrol.drive_accel_mps2", &p.drive_accel_mps2, "m/s^2", "driving acceleration").positive();
  o.add("patrol.turn_rate_radps", &p.turn_rate_radps, "rad/s", "turn rate on the spot").positive();
  o.add("patrol.turn_accel_radps2", &p.turn_accel_radps2, "rad/s^2", "turn acceleration")
      .positive();
  o.add("patrol.pause_min_s", &p.pause_min_s, "s", "shortest pause at a goal").min(0);
  o.add("patrol.pause_max_s", &p.pause_max_s, "s", "longest pause at a goal (>= min)").any();
  o.add("patrol.goals_min", &p.goals_min, "", "fewest goals per patrol").min(1);
  o.add("patrol.goals_max", &p.goals_max, "", "most goals per patrol (>= min)").any();
  o.add("patrol.other_floor_probability", &p.other_floor_probability, "",
        "per patrol, beyond the visits that cover every floor")
      .in(0, 1);
  o.add("patrol.explore_sessions", &p.explore_sessions, "",
        "the whole main floor is reachable from this session on")
      .min(1);
  o.add("patrol.explore_tours", &p.explore_tours, "tours of the main floor and first visits");
  o.add("patrol.roughness_rad", &p.roughness_rad, "rad",
        "amplitude of floor-induced roll and pitch")
      .min(0)
      .below(0.2);
}

void declareElevator(OptionList& o, ElevatorOptions& e) {
  o.add("elevator.accel_min_mps2", &e.accel_min_mps2, "m/s^2", "peak acceleration of a ride, least")
      .positive();
  o.add("elevator.accel_max_mps2", &e.accel_max_mps2, "m/s^2", "... most (>= min)").any();
  o.add("elevator.speed_min_mps", &e.speed_min_mps, "m/s", "cruise speed of a ride, least")
      .positive();
  o.add("elevator.speed_max_mps", &e.speed_max_mps, "m/s", "... most (>= min)").any();
  o.add("elevator.call_wait_max_s", &e.call_wait_max_s, "s", "waiting at the lobby for the cab")
      .min(0);
  o.add("elevator.door_wait_min_s", &e.door_wait_min_s, "s",
        "standing in the cab before and after each ride, least")
      .min(0);
  o.add("elevator.door_wait_max_s", &e.door_wait_max_s, "s", "... most (>= min)").any();
  o.add("elevator.intermediate_stop_probability", &e.intermediate_stop_probability, "",
        "a ride stops at a floor on the way")
      .in(0, 1);
  o.add("elevator.stop_dwell_min_s", &e.stop_dwell_min_s, "s", "an intermediate stop, shortest")
      .min(0);
  o.add("elevator.stop_dwell_max_s", &e.stop_dwell_max_s, "s", "... longest (>= min)").any();
}

void declareCameraAndVo(OptionList& o, SensorOptions& s) {
  o.add("camera.height_m", &s.camera.height_m, "m", "above the floor").any();
  o.add("camera.forward_m", &s.camera.forward_m, "m", "ahead of the body origin").any();
  o.add("camera.fx", &s.camera.fx, "px", "rectified focal length, x").positive();
  o.add("camera.fy", &s.camera.fy, "px", "rectified focal length, y").positive();
  o.add("camera.cx", &s.camera.cx, "px", "principal point, x").positive();
  o.add("camera.cy", &s.camera.cy, "px", "principal point, y").positive();
  o.add("camera.baseline_m", &s.camera.baseline_m, "m", "stereo baseline").positive();
  auto& v = s.vo;
  o.add("vo.rate_hz", &v.rate_hz, "Hz", "VO deltas per second").positive();
  o.add("vo.keyframe_translation_m", &v.keyframe_translation_m, "m",
        "a new reference keyframe after moving this far")
      .min(0);
  o.add("vo.keyframe_rotation_rad", &v.keyframe_rotation_rad, "rad", "... or turning this far")
      .min(0);
  o.add("vo.translation_sigma_m", &v.translation_sigma_m, "m", "translation noise per delta")
      .min(0);
  o.add("vo.translation_sigma_per_m", &v.translation_sigma_per_m, "m/m", "... per metre moved")
      .min(0);
  o.add("vo.translation_sigma_per_rad", &v.translation_sigma_per_rad, "m/rad",
        "... per radian turned")
      .min(0);
  o.add("vo.rotation_sigma_rad", &v.rotation_sigma_rad, "rad", "rotation noise per delta").min(0);
  o.add("vo.rotation_sigma_per_rad", &v.rotation_sigma_per_rad, "rad/rad", "... per radian turned")
      .min(0);
  o.add("vo.rotation_sigma_per_m", &v.rotation_sigma_per_m, "rad/m", "... per metre moved").min(0);
  o.add("vo.fail_in_dark_rooms", &v.fail_in_dark_rooms, "VO fails in dark rooms");
  o.add("vo.fail_at_blank_walls", &v.fail_at_blank_walls, "VO fails turning at blank walls");
  o.add("vo.fail_in_elevator", &v.fail_in_elevator, "VO fails inside the elevator cab");
  o.add("vo.passerby_rate_per_hour", &v.passerby_rate_per_hour, "1/h",
        "passers-by blocking the view (Poisson)")
      .min(0);
  o.add("vo.passerby_min_s", &v.passerby_min_s, "s", "a passer-by blocks the view at least").min(0);
  o.add("vo.passerby_max_s", &v.passerby_max_s, "s", "... at most (>= min)").any();
}

void declareWheel(OptionList& o, WheelOptions& w) {
  o.add("wheel.rate_hz", &w.rate_hz, "Hz", "wheel odometry increments per second").positive();
  o.add("wheel.sigma_m", &w.sigma_m, "m", "translation noise per increment").min(0);
  o.add("wheel.sigma_rad", &w.sigma_rad, "rad", "heading noise per increment").min(0);
  o.add("wheel.sigma_forward_per_m", &w.sigma_forward_per_m, "m/m", "forward noise per metre")
      .min(0);
  o.add("wheel.sigma_lateral_per_m", &w.sigma_lateral_per_m, "m/m", "lateral noise per metre")
      .min(0);
  o.add("wheel.sigma_theta_per_m", &w.sigma_theta_per_m, "rad/m", "heading noise per metre").min(0);
  o.add("wheel.sigma_theta_per_rad", &w.sigma_theta_per_rad, "rad/rad",
        "heading noise per radian turned")
      .min(0);
  o.add("wheel.slip_rate_per_hour", &w.slip_rate_per_hour, "1/h", "slip events (Poisson)").min(0);
  o.add("wheel.slip_min_s", &w.slip_min_s, "s", "a slip lasts at least").min(0);
  o.add("wheel.slip_max_s", &w.slip_max_s, "s", "... at most (>= min)").any();
  o.add("wheel.slip_min_fraction", &w.slip_min_fraction, "",
        "a slip scales the translation by 1 + f, f at least")
      .min(0);
  o.add("wheel.slip_max_fraction", &w.slip_max_fraction, "", "... at most (>= min)").below(1);
  o.add("wheel.slip_yaw_rad_per_m", &w.slip_yaw_rad_per_m, "rad/m", "yaw error of a slip").min(0);
}

void declareAttitudeAndFloor(OptionList& o, SensorOptions& s) {
  auto& a = s.attitude;
  o.add("attitude.rate_hz", &a.rate_hz, "Hz", "ATTITUDE messages per second").positive();
  o.add("attitude.sigma_rad", &a.sigma_rad, "rad", "roll and pitch noise").min(0);
  o.add("attitude.untrusted_accel_mps2", &a.untrusted_accel_mps2, "m/s^2",
        "accel_trusted is 0 above this acceleration")
      .positive();
  o.add("attitude.heading", &a.heading, "publish the gyro's heading (imu-proc's)");
  o.add("attitude.heading_noise_density", &a.heading_noise_density, "rad/s/sqrt(Hz)",
        "gyro white noise, integrated")
      .min(0);
  o.add("attitude.heading_bias_sigma_rad_s", &a.heading_bias_sigma_rad_s, "rad/s",
        "bias left after a zero-rate update")
      .min(0);
  o.add("attitude.heading_bias_walk_density", &a.heading_bias_walk_density, "rad/s^2/sqrt(Hz)",
        "bias random walk")
      .min(0);
  o.add("attitude.heading_scale_sigma", &a.heading_scale_sigma, "", "gyro scale error per session")
      .min(0);
  o.add("attitude.heading_still_s", &a.heading_still_s, "s",
        "standing still this long: a zero-rate update")
      .positive();
  o.add("floor.height_sigma_m", &s.floor.height_sigma_m, "m", "ride height noise").min(0);
  o.add("floor.height_sigma_per_m", &s.floor.height_sigma_per_m, "m/m", "... per metre ridden")
      .min(0);
  o.add("floor.match_threshold_m", &s.floor.match_threshold_m, "m",
        "arrival matches a known floor within this")
      .positive();
}

void declareImu(OptionList& o, SensorOptions& s) {
  auto& i = s.imu;
  o.add("imu.enabled", &i.enabled, "raw IMU samples around elevator rides");
  o.add("imu.rate_hz", &i.rate_hz, "Hz", "IMU samples per second").positive();
  o.add("imu.margin_s", &i.margin_s, "s", "before and after each ride").min(0);
  o.add("imu.accel_sigma_mps2", &i.accel_sigma_mps2, "m/s^2", "accelerometer white noise").min(0);
  o.add("imu.gyro_sigma_radps", &i.gyro_sigma_radps, "rad/s", "gyro white noise").min(0);
  o.add("imu.gyro_bias_sigma_radps", &i.gyro_bias_sigma_radps, "rad/s",
        "gyro turn-on bias per axis and session")
      .min(0);
  o.add("imu.accel_bias_sigma_mps2", &i.accel_bias_sigma_mps2, "m/s^2",
        "accelerometer bias per axis and session")
      .min(0);
  o.add("imu.gravity_mps2", &i.gravity_mps2, "m/s^2", "gravity").positive();
  o.add("ground_truth.rate_hz", &s.ground_truth_rate_hz, "Hz", "GROUND_TRUTH poses per second")
      .positive();
}

void declareOracle(OptionList& o, OracleOptions& r) {
  o.add("oracle.max_distance_m", &r.max_distance_m, "m", "registration needs the node this near")
      .positive();
  o.add("oracle.max_view_angle_rad", &r.max_view_angle_rad, "rad",
        "... and the views this close in heading")
      .positive();
  o.add("oracle.success_probability", &r.success_probability, "",
        "a registration at distance and angle 0 succeeds")
      .in(0, 1);
  o.add("oracle.distance_scale_m", &r.distance_scale_m, "m", "success falls off over this distance")
      .positive();
  o.add("oracle.angle_scale_rad", &r.angle_scale_rad, "rad", "... and this angle").positive();
  o.add("oracle.global_candidates", &r.global_candidates, "",
        "nodes a global (place recognition) request tries")
      .min(1);
  o.add("oracle.false_match_rate_node", &r.false_match_rate_node, "",
        "a request against a given node returns a false match")
      .in(0, 1);
  o.add("oracle.false_match_rate_global", &r.false_match_rate_global, "",
        "a global request returns a false match")
      .in(0, 1);
  o.add("oracle.translation_sigma_m", &r.translation_sigma_m, "m", "registration noise").min(0);
  o.add("oracle.translation_sigma_per_m", &r.translation_sigma_per_m, "m/m", "... per metre apart")
      .min(0);
  o.add("oracle.rotation_sigma_rad", &r.rotation_sigma_rad, "rad", "registration rotation noise")
      .min(0);
  o.add("oracle.rotation_sigma_per_rad", &r.rotation_sigma_per_rad, "rad/rad",
        "... per radian apart")
      .min(0);
  o.add("oracle.min_inliers", &r.min_inliers, "", "inliers reported, least").min(0);
  o.add("oracle.max_inliers", &r.max_inliers, "", "... most (>= min)").any();
  o.add("oracle.keyframe_window_s", &r.keyframe_window_s, "s",
        "> 0: forget keyframes older than this behind the newest")
      .min(0);
}

}  // namespace

void SimOptions::declareOptions(OptionList& o) {
  o.choice("mode", &mode, {{"building", Mode::kBuilding}, {"trajectory", Mode::kTrajectory}},
           "patrol a generated building, or drive along trajectory.file");
  o.add("seed", &seed, "", "of every random draw of the run").any();
  declareBuilding(o, building);
  declarePatrol(o, patrol);
  declareElevator(o, elevator);
  declareCameraAndVo(o, sensors);
  declareWheel(o, sensors.wheel);
  declareAttitudeAndFloor(o, sensors);
  declareImu(o, sensors);
  declareOracle(o, oracle);
  o.add("trajectory.file", &trajectory.file, "",
        "mode = trajectory: KITTI poses (relative to the config)");
  o.add("trajectory.rate_hz", &trajectory.rate_hz, "Hz", "of the poses in the file").positive();
  o.add("trajectory.first", &trajectory.first, "", "first pose used").min(0);
  o.add("trajectory.count", &trajectory.count, "", "poses used (0: to the end; else >= 2)").min(0);
  o.add("output.split_sessions", &output.split_sessions,
        "one log per session (else one for the run)");
  o.add("output.tum", &output.tum, "ground truth in TUM format beside each log");
}

}  // namespace evermap::sim
