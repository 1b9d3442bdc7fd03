#pragma once
// A synthetic building for the elevator tracker: a person or robot that stands, walks,
// sits down, takes the stairs or an escalator, and rides elevators between floors, with
// the IMU samples such motion produces (gravity, attitude sway, noise, accelerometer bias)
// and the true rides. It stands in for the measurement-level simulator (DESIGN.md
// section 8) until that exists.
//
// Elevator profile: jerk-limited, as lift controllers drive them: the acceleration ramps at
// the jerk j to a_max, holds, ramps down as the speed reaches v; a cruise at v; the mirrored
// stop. A ride too short to reach v peaks lower.

#include <cstdint>
#include <string>
#include <vector>

#include "core/imu/sample_gate.h"

namespace evermap::elevator {

struct RideSimulatorOptions {
  double rate_hz = 100.0;
  int floors = 10;
  double floor_height_m = 3.6;     // floors above the lobby (storey)
  double lobby_height_m = 4.5;     // floor 0 to floor 1
  double accel_noise_m_s2 = 0.05;  // white, per sample, each axis
  double gyro_noise_rad_s = 0.005;
  Eigen::Vector3d accel_bias_m_s2{0.04, -0.06, 0.08};
  Eigen::Vector3d gyro_bias_rad_s{0.01, -0.005, 0.008};
  // Elevator motion, drawn per ride from these ranges.
  double min_ride_accel_m_s2 = 0.5, max_ride_accel_m_s2 = 1.0;
  double min_ride_speed_m_s = 1.0, max_ride_speed_m_s = 2.0;
  double ride_jerk_m_s3 = 1.0;
  // false: an IMU without a gyroscope (every gyro reading 0, as the readers give it).
  bool gyroscope = true;
  // Vertical speed of escalators (a common one: 0.5 m/s along a 30 deg incline is 0.25 m/s
  // vertical; 0.5 m/s vertical is a fast one) and of walking up or down the stairs.
  double escalator_speed_m_s = 0.3;
  double stairs_up_speed_m_s = 0.25, stairs_down_speed_m_s = 0.3;
  double time_jitter_s = 0.0;  // uniform +- on each time stamp
  uint32_t seed = 1;
};

struct SimSegment {
  enum class Kind { kStand, kWalk, kSitDown, kStairs, kEscalator, kElevator };
  Kind kind = Kind::kStand;
  double duration_s = 10.0;  // kStand, kWalk, kStairs (kElevator: from the profile)
  int to_floor = 0;          // kElevator, kStairs, kEscalator: the floor reached
  // kElevator: standing in the cab before the ride starts and after it stops, s (the gap
  // between the walk into the cab and the ride); < 0: 3-6 s before, 1-3 s after.
  double stand_before_s = -1, stand_after_s = -1;
};

struct TrueRide {
  double start_s = 0, end_s = 0;
  int from_floor = 0, to_floor = 0;
  double displacement_m = 0;
};

struct SimulatedRun {
  std::vector<imu::ImuSample> samples;
  std::vector<TrueRide> rides;
  // Intervals of walking, stairs, sitting down and escalators: no ride may be reported there.
  std::vector<std::pair<double, double>> no_ride_intervals;
  std::vector<double> floor_heights;  // true height of each floor, m
};

double floorHeight(const RideSimulatorOptions& o, int floor);

SimulatedRun simulateRun(const RideSimulatorOptions& options,
                         const std::vector<SimSegment>& script);

// A day in the building: n elevator rides between random floors, each between walks,
// with sitting down, stairs and escalators (up and back: the tracker follows elevator
// transitions only, as the paper's robot) in between.
std::vector<SimSegment> randomScript(const RideSimulatorOptions& options, int rides, uint32_t seed);

}  // namespace evermap::elevator
