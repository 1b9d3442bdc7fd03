#include "tools/imu-elevator-run/ride_simulator.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>

#include "core/geometry/so3.h"

namespace evermap::elevator {

namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kG = 9.80665;
constexpr double kDeg = kPi / 180.0;

// Moves x towards target by at most rate * dt (smooth amplitude and posture changes, so
// the gyro stays within a real sensor's range).
double approach(double x, double target, double rate, double dt) {
  const double step = rate * dt;
  return x + std::clamp(target - x, -step, step);
}

// Elevator acceleration at time t into a ride of distance d (signed): jerk-limited, an
// acceleration plateau at a_max reached with jerk j, a cruise at v, and the mirrored stop.
// A ride too short for the cruise lowers v (bisection on the distance).
struct RideProfile {
  double a = 0.7, v = 1.5, j = 1.0, sign = 1, t_ramp = 0, t_plateau = 0, t_cruise = 0;
  RideProfile(double distance, double a_max, double v_max, double jerk)
      : a(a_max), v(v_max), j(jerk) {
    sign = distance >= 0 ? 1.0 : -1.0;
    const double D = std::abs(distance);
    double lo = 0.05, hi = v_max;
    for (int i = 0; i < 60; ++i) {
      shape(0.5 * (lo + hi));
      if (accelDistance() * 2 > D)
        hi = 0.5 * (lo + hi);
      else
        lo = 0.5 * (lo + hi);
    }
    shape(lo);
    t_cruise = std::max(0.0, (D - 2 * accelDistance()) / v);
  }
  void shape(double v_peak) {
    v = v_peak;
    // Ramps of a / j; if v is too small for the plateau, a triangle of lower peak.
    double a_peak = a;
    if (a_peak * a_peak / j > v) a_peak = std::sqrt(v * j);
    t_ramp = a_peak / j;
    t_plateau = v / a_peak - t_ramp;
    peak = a_peak;
  }
  double peak = 0;
  double accelPhase() const { return 2 * t_ramp + t_plateau; }
  double accelDistance() const { return 0.5 * v * accelPhase(); }  // symmetric profile
  double duration() const { return 2 * accelPhase() + t_cruise; }
  double phase(double t) const {  // acceleration of one start phase
    if (t < 0) return 0;
    if (t < t_ramp) return j * t;
    if (t < t_ramp + t_plateau) return peak;
    if (t < accelPhase()) return peak - j * (t - t_ramp - t_plateau);
    return 0;
  }
  double accel(double t) const {
    if (t < accelPhase()) return sign * phase(t);
    t -= accelPhase() + t_cruise;
    return -sign * phase(t);
  }
};

struct Generator {
  const RideSimulatorOptions& o;
  std::mt19937 rng;
  std::normal_distribution<double> normal{0.0, 1.0};
  std::uniform_real_distribution<double> uniform{0.0, 1.0};
  SimulatedRun run;
  double t = 0;  // s
  double dt = 0;
  int floor = 0;
  double height = 0, vz = 0;
  // Posture: sway amplitudes, lean, heading.
  double sway = 1.0 * kDeg, lean = 0, yaw = 0;
  core::SO3d person_R_phone;
  core::SO3d last_R;
  bool first = true;

  explicit Generator(const RideSimulatorOptions& options) : o(options), rng(options.seed) {
    dt = 1.0 / o.rate_hz;
    // The phone sits upright in a pocket, a little turned.
    person_R_phone = core::SO3d::fromRollPitchYaw(10 * kDeg, -70 * kDeg, 20 * kDeg);
    for (int f = 0; f < o.floors; ++f) run.floor_heights.push_back(floorHeight(o, f));
  }

  // One sample: world acceleration a_w (m/s^2), the person's posture targets.
  void emit(const Eigen::Vector3d& a_w, double sway_target, double lean_target, double yaw_rate) {
    sway = approach(sway, sway_target, 4 * kDeg, dt);
    lean = approach(lean, lean_target, 30 * kDeg, dt);
    yaw += yaw_rate * dt;
    const double roll = sway * std::sin(2 * kPi * 0.9 * t);
    const double pitch = lean + 0.7 * sway * std::sin(2 * kPi * 0.6 * t + 1.0);
    const core::SO3d world_R_person = core::SO3d::fromRollPitchYaw(roll, pitch, yaw);
    const core::SO3d R = world_R_person * person_R_phone;
    imu::ImuSample s;
    double ts = t;
    if (o.time_jitter_s > 0) ts += o.time_jitter_s * (2 * uniform(rng) - 1);
    s.utime = static_cast<int64_t>(std::llround(ts * 1e6));
    const Eigen::Vector3d w =
        first ? Eigen::Vector3d::Zero() : Eigen::Vector3d((last_R.inverse() * R).log() / dt);
    s.gyro_rad_s = w + o.gyro_bias_rad_s + o.gyro_noise_rad_s * noise3();
    if (!o.gyroscope) s.gyro_rad_s.setZero();
    s.accel_m_s2 = R.inverse() * (a_w + Eigen::Vector3d(0, 0, kG)) + o.accel_bias_m_s2 +
                   o.accel_noise_m_s2 * noise3();
    run.samples.push_back(s);
    last_R = R;
    first = false;
    vz += a_w.z() * dt;
    height += vz * dt;
    t += dt;
  }
  Eigen::Vector3d noise3() { return {normal(rng), normal(rng), normal(rng)}; }

  // Heading-frame horizontal acceleration to world.
  Eigen::Vector3d horizontal(double forward, double left) const {
    return {forward * std::cos(yaw) - left * std::sin(yaw),
            forward * std::sin(yaw) + left * std::cos(yaw), 0.0};
  }

  void stand(double duration) {
    for (double e = 0; e < duration; e += dt) emit(Eigen::Vector3d::Zero(), 1.0 * kDeg, 0, 0);
  }
  // Walking: a cadence of 1.6-2.2 Hz and a vertical bounce of 1.5-2.5 m/s^2 (bounce < 0) or
  // the bounce given, drawn per walk; each step its own period (+-5 %) and amplitude
  // (+-20 %), the left and right steps differing by up to 10 % (a stride component at half
  // the cadence, as a real gait has), a second harmonic, fore-aft surges and turns. Each
  // sample carries the mean of the bounce over its interval, and the walk ends on a whole
  // step, so the bounce's velocity starts and ends at 0 (the person does not drift upward).
  void walk(double duration, double vz_target = 0.0, double bounce = -1.0) {
    const double cadence = 1.6 + 0.6 * uniform(rng);
    const double mean_bounce = bounce > 0 ? bounce : 1.5 + uniform(rng);
    const double stride = 1.0 + 0.1 * (2 * uniform(rng) - 1);
    const double turn = 0.4 * (2 * uniform(rng) - 1);
    const int steps = std::max(2, static_cast<int>(std::lround(duration * cadence)));
    double f = cadence, amplitude = mean_bounce, phase = 0;  // phase: 2 pi per step
    double v_ctrl = vz;
    for (double e = 0; phase < 2 * kPi * steps; e += dt) {
      // The carried vertical speed moves to the target within ~1 s (stairs, escalators).
      const double a_ctrl = std::clamp((vz_target - v_ctrl) / 1.0, -0.5, 0.5);
      v_ctrl += a_ctrl * dt;
      const double step = std::floor(phase / (2 * kPi));
      const double next = std::min(phase + 2 * kPi * f * dt, 2 * kPi * steps);
      // The bounce A cos(phase) + 0.3 A cos(2 phase + 0.5) integrated over the interval.
      const double dv = amplitude * (std::sin(next) - std::sin(phase) +
                                     0.15 * (std::sin(2 * next + 0.5) - std::sin(2 * phase + 0.5)));
      const double az = a_ctrl + dv / (2 * kPi * f * dt);
      const Eigen::Vector3d a =
          horizontal(1.2 * std::sin(phase + 1.0), 0.6 * std::sin(0.5 * phase)) +
          Eigen::Vector3d(0, 0, az);
      emit(a, 5.0 * kDeg, 0, turn * std::sin(0.5 * e));
      phase = next;
      if (std::floor(phase / (2 * kPi)) > step) {  // a new step: its own period and force
        f = cadence * (1.0 + 0.05 * std::clamp(normal(rng), -2.0, 2.0));
        const double side = static_cast<int>(step) % 2 == 0 ? stride : 1.0 / stride;
        amplitude = mean_bounce * side * (0.8 + 0.4 * uniform(rng));
      }
    }
  }
  void sitDown() {
    walk(3.0);
    const int start = static_cast<int>(run.no_ride_intervals.size());
    (void)start;
    // Down 0.45 m in 1.2 s (velocity returns to zero), leaning back 20 deg, then sitting.
    for (double e = 0; e < 1.2; e += dt) {
      emit(Eigen::Vector3d(0, 0, -0.45 * 2 * kPi / (1.2 * 1.2) * std::sin(2 * kPi * e / 1.2)),
           2.0 * kDeg, -20 * kDeg, 0);
    }
    for (double e = 0; e < 20.0; e += dt) emit(Eigen::Vector3d::Zero(), 0.5 * kDeg, -20 * kDeg, 0);
    for (double e = 0; e < 1.2; e += dt) {
      emit(Eigen::Vector3d(0, 0, 0.45 * 2 * kPi / (1.2 * 1.2) * std::sin(2 * kPi * e / 1.2)),
           2.0 * kDeg, 0, 0);
    }
  }
  // stand_before_s / stand_after_s < 0: 3-6 s for the doors to close, 1-3 s to open.
  void elevator(int to_floor, double stand_before_s, double stand_after_s) {
    stand(stand_before_s >= 0 ? stand_before_s : 3.0 + 3.0 * uniform(rng));
    const double distance = floorHeight(o, to_floor) - floorHeight(o, floor);
    const double a =
        o.min_ride_accel_m_s2 + (o.max_ride_accel_m_s2 - o.min_ride_accel_m_s2) * uniform(rng);
    const double v =
        o.min_ride_speed_m_s + (o.max_ride_speed_m_s - o.min_ride_speed_m_s) * uniform(rng);
    const RideProfile p(distance, a, v, o.ride_jerk_m_s3);
    TrueRide r;
    r.start_s = t;
    r.from_floor = floor;
    r.to_floor = to_floor;
    r.displacement_m = distance;
    // Each sample carries the mean acceleration over its interval (midpoint rule on 16
    // sub-steps), so the samples integrate to the profile's velocity and the cabin comes to
    // rest: sampling the profile at instants would leave up to a_max dt of velocity at 10 Hz.
    const int steps = static_cast<int>(std::ceil(p.duration() / dt));
    for (int k = 0; k < steps; ++k) {
      double mean = 0;
      for (int i = 0; i < 16; ++i) mean += p.accel((k + (i + 0.5) / 16.0) * dt) / 16.0;
      emit(Eigen::Vector3d(0, 0, mean), 1.0 * kDeg, 0, 0);
    }
    r.end_s = t;
    run.rides.push_back(r);
    vz = 0;  // the cabin stops exactly at the floor
    height = floorHeight(o, to_floor);
    floor = to_floor;
    stand(stand_after_s >= 0 ? stand_after_s : 1.0 + 2.0 * uniform(rng));
  }
  void stairs(int to_floor) {
    const double distance = floorHeight(o, to_floor) - floorHeight(o, floor);
    const double vz_target = distance > 0 ? o.stairs_up_speed_m_s : -o.stairs_down_speed_m_s;
    const double begin = t;
    walk(std::abs(distance / vz_target) + 1.0, vz_target, 3.5);
    walk(1.5, 0.0);
    run.no_ride_intervals.push_back({begin, t});
    vz = 0;
    height = floorHeight(o, to_floor);
    floor = to_floor;
  }
  void escalator(int to_floor) {
    const double distance = floorHeight(o, to_floor) - floorHeight(o, floor);
    const double vz_target = distance > 0 ? o.escalator_speed_m_s : -o.escalator_speed_m_s;
    const double begin = t;
    walk(3.0);
    walk(1.0, vz_target);  // stepping on while the step carries you
    const double ride = std::abs(distance / vz_target) - 1.0;
    for (double e = 0; e < ride; e += dt) {
      emit(Eigen::Vector3d(0, 0, (vz_target - vz) / 0.5), 1.5 * kDeg, 0, 0);
    }
    walk(3.0, 0.0);  // stepping off
    run.no_ride_intervals.push_back({begin, t});
    vz = 0;
    height = floorHeight(o, to_floor);
    floor = to_floor;
  }
};

}  // namespace

double floorHeight(const RideSimulatorOptions& o, int floor) {
  if (floor <= 0) return 0.0;
  return o.lobby_height_m + (floor - 1) * o.floor_height_m;
}

SimulatedRun simulateRun(const RideSimulatorOptions& options,
                         const std::vector<SimSegment>& script) {
  Generator g(options);
  g.stand(5.0);  // the IMU starts at rest
  for (const SimSegment& s : script) {
    const double begin = g.t;
    switch (s.kind) {
      case SimSegment::Kind::kStand:
        g.stand(s.duration_s);
        break;
      case SimSegment::Kind::kWalk:
        g.walk(s.duration_s);
        g.run.no_ride_intervals.push_back({begin, g.t});
        break;
      case SimSegment::Kind::kSitDown:
        g.sitDown();
        g.run.no_ride_intervals.push_back({begin, g.t});
        break;
      case SimSegment::Kind::kStairs:
        g.stairs(s.to_floor);
        break;
      case SimSegment::Kind::kEscalator:
        g.escalator(s.to_floor);
        break;
      case SimSegment::Kind::kElevator:
        g.elevator(s.to_floor, s.stand_before_s, s.stand_after_s);
        break;
    }
  }
  g.stand(10.0);
  return std::move(g.run);
}

std::vector<SimSegment> randomScript(const RideSimulatorOptions& options, int rides,
                                     uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> floor_of(0, options.floors - 1);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  using K = SimSegment::Kind;
  std::vector<SimSegment> script;
  int floor = 0;
  for (int i = 0; i < rides; ++i) {
    script.push_back({K::kWalk, 5.0 + 10.0 * u(rng), 0});
    const double r = u(rng);
    if (r < 0.15) {
      script.push_back({K::kSitDown, 0, 0});
      script.push_back({K::kWalk, 5.0, 0});
    } else if (r < 0.3 && floor + 1 < options.floors) {
      // Up the stairs and back: the elevator tracker does not see stairs (by design: it
      // tracks elevator transitions), so the floor must be the same at the next ride.
      script.push_back({K::kStairs, 0, floor + 1});
      script.push_back({K::kWalk, 4.0, 0});
      script.push_back({K::kStairs, 0, floor});
    } else if (r < 0.4 && floor > 0) {
      script.push_back({K::kEscalator, 0, floor - 1});
      script.push_back({K::kWalk, 4.0, 0});
      script.push_back({K::kEscalator, 0, floor});
    } else if (r < 0.5) {
      script.push_back({K::kStand, 10.0 + 20.0 * u(rng), 0});
    }
    int to = floor_of(rng);
    if (to == floor)
      to = (floor + 1 + static_cast<int>(u(rng) * (options.floors - 1))) % options.floors;
    script.push_back({K::kElevator, 0, to});
    floor = to;
  }
  script.push_back({K::kWalk, 8.0, 0});
  return script;
}

}  // namespace evermap::elevator
