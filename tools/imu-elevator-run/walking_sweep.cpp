#include "tools/imu-elevator-run/walking_sweep.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace evermap::elevator {

double walkingSweepBound(double displacement_m) { return 0.03 * std::abs(displacement_m) + 0.3; }

namespace {

RideSimulatorOptions cellSimulator(double rate_hz, bool gyroscope, uint32_t seed) {
  RideSimulatorOptions o;
  o.rate_hz = rate_hz;
  o.gyroscope = gyroscope;
  o.seed = seed;
  o.floors = 6;
  // One storey per run, 3-4 m (lobby included), from the seed.
  o.floor_height_m = 3.0 + static_cast<double>(seed % 11) / 10.0;
  o.lobby_height_m = o.floor_height_m;
  o.min_ride_speed_m_s = 0.8;
  o.max_ride_speed_m_s = 1.2;
  o.min_ride_accel_m_s2 = 0.5;
  o.max_ride_accel_m_s2 = 1.0;
  o.accel_noise_m_s2 = 0.004 * std::sqrt(rate_hz / 2.0);  // a phone's density, per sample
  o.accel_bias_m_s2 = 0.05 * Eigen::Vector3d(1.0, -0.6, 0.8);
  return o;
}

// Walk, ride (gap standing on either side), walk ...: four one-floor rides, one of three.
std::vector<SimSegment> cellScript(double gap_s) {
  using K = SimSegment::Kind;
  std::vector<SimSegment> script;
  const int floors[] = {1, 2, 1, 4, 3};
  const double walks[] = {6.0, 5.0, 7.0, 5.5, 6.5};
  for (int i = 0; i < 5; ++i) {
    script.push_back({K::kWalk, walks[i], 0});
    SimSegment ride{K::kElevator, 0, floors[i]};
    ride.stand_before_s = ride.stand_after_s = gap_s;
    script.push_back(ride);
  }
  script.push_back({K::kWalk, 8.0, 0});
  return script;
}

}  // namespace

void scoreRides(const SimulatedRun& truth, const OfflineRun& run, RideScore* score) {
  std::vector<int> hits(truth.rides.size(), 0);
  char line[256];
  for (const Ride& r : run.rides) {
    const double s = 1e-6 * static_cast<double>(r.start_utime);
    const double e = 1e-6 * static_cast<double>(r.end_utime);
    int match = -1;
    for (size_t i = 0; i < truth.rides.size(); ++i) {
      if (s < truth.rides[i].end_s && e > truth.rides[i].start_s) match = static_cast<int>(i);
    }
    if (match < 0 || ++hits[match] > 1) {
      ++score->false_rides;
      std::snprintf(line, sizeof line, "false ride %.1f..%.1f s, %.2f m", s, e, r.displacement_m);
      score->failures.push_back(line);
      continue;
    }
    const TrueRide& t = truth.rides[match];
    const double err = r.displacement_m - t.displacement_m;
    score->worst_error_m = std::max(score->worst_error_m, std::abs(err));
    score->errors_m.push_back(err);
    score->bounds_m.push_back(walkingSweepBound(t.displacement_m));
    if (std::abs(t.to_floor - t.from_floor) == 1) score->one_floor_errors_m.push_back(err);
    if (std::abs(err) > walkingSweepBound(t.displacement_m)) {
      ++score->outside_bound;
      std::snprintf(line, sizeof line, "ride %.1f..%.1f s: %.2f m for %.2f m", t.start_s, t.end_s,
                    r.displacement_m, t.displacement_m);
      score->failures.push_back(line);
    }
  }
  for (size_t i = 0; i < truth.rides.size(); ++i) {
    ++score->rides;
    if (hits[i] > 0) {
      ++score->found;
      continue;
    }
    ++score->missed;
    std::string why;
    for (const AbandonedRide& a : run.abandoned) why += " abandoned: " + a.reason + ";";
    for (const RejectedRide& r : run.rejected) why += " rejected: " + r.reason + ";";
    std::snprintf(line, sizeof line, "missed ride %.1f..%.1f s (%.2f m);", truth.rides[i].start_s,
                  truth.rides[i].end_s, truth.rides[i].displacement_m);
    score->failures.push_back(line + why);
  }
  score->rejected += static_cast<int>(run.rejected.size());
  score->abandoned += static_cast<int>(run.abandoned.size());
}

std::vector<WalkingSweepCell> runWalkingSweep(const ElevatorTrackerOptions& options) {
  std::vector<WalkingSweepCell> cells;
  uint32_t seed = 500;
  for (double rate : {10.0, 50.0, 200.0}) {
    for (bool gyro : {true, false}) {
      for (double gap : {0.5, 1.0, 2.0, 3.0}) {
        WalkingSweepCell cell;
        cell.rate_hz = rate;
        cell.gyroscope = gyro;
        cell.gap_s = gap;
        const SimulatedRun truth = simulateRun(cellSimulator(rate, gyro, ++seed), cellScript(gap));
        scoreRides(truth, runImuElevator(truth.samples, {}, options), &cell);
        cells.push_back(std::move(cell));
      }
    }
  }
  return cells;
}

std::string formatWalkingSweep(const std::vector<WalkingSweepCell>& cells) {
  std::string out =
      "| rate | gyro | gap | rides | found | missed | false | rejected | abandoned | worst error "
      "| one-floor errors (m) |\n|---|---|---|---|---|---|---|---|---|---|---|\n";
  WalkingSweepCell all;
  char buf[512];
  for (const WalkingSweepCell& c : cells) {
    std::string errors;
    for (double e : c.one_floor_errors_m) {
      std::snprintf(buf, sizeof buf, "%s%+.2f", errors.empty() ? "" : " ", e);
      errors += buf;
    }
    std::snprintf(buf, sizeof buf,
                  "| %.0f Hz | %s | %.1f s | %d | %d | %d | %d | %d | %d | %.2f m | %s |\n",
                  c.rate_hz, c.gyroscope ? "yes" : "no", c.gap_s, c.rides, c.found, c.missed,
                  c.false_rides, c.rejected, c.abandoned, c.worst_error_m, errors.c_str());
    out += buf;
    all.rides += c.rides;
    all.found += c.found;
    all.missed += c.missed;
    all.false_rides += c.false_rides;
    all.rejected += c.rejected;
    all.abandoned += c.abandoned;
    all.worst_error_m = std::max(all.worst_error_m, c.worst_error_m);
    for (double e : c.one_floor_errors_m) all.one_floor_errors_m.push_back(std::abs(e));
  }
  std::vector<double>& e = all.one_floor_errors_m;
  std::sort(e.begin(), e.end());
  std::snprintf(buf, sizeof buf,
                "| all | | | %d | %d | %d | %d | %d | %d | %.2f m | median |error| %.2f m, worst "
                "%.2f m (%zu rides) |\n",
                all.rides, all.found, all.missed, all.false_rides, all.rejected, all.abandoned,
                all.worst_error_m, e.empty() ? 0.0 : e[e.size() / 2], e.empty() ? 0.0 : e.back(),
                e.size());
  out += buf;
  return out;
}

}  // namespace evermap::elevator
