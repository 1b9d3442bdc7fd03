#pragma once
// Shared set-up for the measurement-level simulator tests: a small building and short runs
// (minutes of simulated time), noise switches, and decoding of captured messages.

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "tools/sim/message_sink.h"
#include "tools/sim/run.h"

namespace evermap::sim::testing {

// The small building of the simulator and mapper tests: 3 floors, the main one in the middle,
// 4 cross corridors on each; the patrol is left at its defaults.
inline SimOptions smallBuilding(uint64_t seed) {
  SimOptions o;
  o.seed = seed;
  o.building.floors = 3;
  o.building.main_floor = 1;
  o.building.main_cross_corridors = 4;
  o.building.max_cross_corridors = 4;
  return o;
}

// smallBuilding(seed) patrolled in `sessions` sessions over `span_days` days, `total_hours` in
// all; the whole main floor is reachable from session `explore_sessions` on.
inline SimOptions smallPatrol(uint64_t seed, int sessions, double total_hours, int span_days,
                              int explore_sessions) {
  SimOptions o = smallBuilding(seed);
  o.patrol.sessions = sessions;
  o.patrol.total_hours = total_hours;
  o.patrol.span_days = span_days;
  o.patrol.explore_sessions = explore_sessions;
  return o;
}

// 3 floors, 2 sessions, about 8 minutes of patrol in all; every floor is visited.
inline SimOptions smallRun(uint64_t seed = 11) {
  SimOptions o = smallPatrol(seed, 2, 0.12, 3, 1);
  o.elevator.intermediate_stop_probability = 0.5;
  return o;
}

// Every sensor exact: no noise, no slip, no bias (failures are switched separately).
inline void removeNoise(SimOptions& o) {
  auto& vo = o.sensors.vo;
  vo.translation_sigma_m = vo.translation_sigma_per_m = vo.translation_sigma_per_rad = 0.0;
  vo.rotation_sigma_rad = vo.rotation_sigma_per_rad = vo.rotation_sigma_per_m = 0.0;
  auto& w = o.sensors.wheel;
  w.sigma_m = w.sigma_rad = w.sigma_forward_per_m = w.sigma_lateral_per_m = 0.0;
  w.sigma_theta_per_m = w.sigma_theta_per_rad = 0.0;
  w.slip_rate_per_hour = 0.0;
  o.sensors.attitude.sigma_rad = 0.0;
  o.sensors.floor.height_sigma_m = o.sensors.floor.height_sigma_per_m = 0.0;
  o.sensors.imu.accel_sigma_mps2 = o.sensors.imu.gyro_sigma_radps =
      o.sensors.imu.accel_bias_sigma_mps2 = 0.0;
  o.sensors.imu.gyro_bias_sigma_radps = 0.0;
}

inline void removeVoFailures(SimOptions& o) {
  o.sensors.vo.fail_in_dark_rooms = false;
  o.sensors.vo.fail_at_blank_walls = false;
  o.sensors.vo.fail_in_elevator = false;
  o.sensors.vo.passerby_rate_per_hour = 0.0;
}

// Decodes every captured message of one channel as T (failing the test on a bad one).
template <typename T>
std::vector<T> decodeAll(const VectorSink& sink, const std::string& channel) {
  std::vector<T> out;
  for (const auto& m : sink.messages) {
    if (m.channel != channel) continue;
    T t;
    const int n = t.decode(m.data.data(), 0, static_cast<int>(m.data.size()));
    EXPECT_EQ(n, static_cast<int>(m.data.size())) << channel << " message does not decode";
    out.push_back(t);
  }
  return out;
}

}  // namespace evermap::sim::testing
