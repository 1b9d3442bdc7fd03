#pragma once
// Elevator rides next to walking (issue 50), on the ride simulator: for every IMU rate
// (10, 50, 200 Hz), with and without a gyroscope, and for every gap between the walk and
// the ride (0.5, 1, 2, 3 s standing in the cab before the start and after the stop), one
// run of a person walking between five rides: four one-floor rides and one of three floors,
// on storeys of 3-4 m at 0.8-1.2 m/s (0.5-1.0 m/s^2), as office lifts and the HackZurich
// building. A ride is found when one reported ride overlaps it in time; a reported ride that
// overlaps none, or a second one on the same ride, is false. Deterministic (seeded).
// elevator_sweep_test asserts it; `evermap-imu-elevator-run --walking-sweep` prints it.

#include <string>
#include <vector>

#include "elevator-proc/elevator_tracker.h"
#include "tools/imu-elevator-run/offline_run.h"
#include "tools/imu-elevator-run/ride_simulator.h"

namespace evermap::elevator {

// Reported rides against a simulated run's true rides: a reported ride is found when it
// overlaps a true ride in time; one that overlaps none, or a second one on the same ride, is
// false. Adds to what `score` holds.
struct RideScore {
  int rides = 0, found = 0, missed = 0, false_rides = 0, rejected = 0, abandoned = 0;
  int outside_bound = 0;  // found rides with |error| > walkingSweepBound
  double worst_error_m = 0;
  std::vector<double> errors_m;            // signed: found - true, each ride found
  std::vector<double> bounds_m;            // walkingSweepBound of each, in the same order
  std::vector<double> one_floor_errors_m;  // the same, each one-floor ride found
  std::vector<std::string> failures;       // one line per miss, false ride or error
};
void scoreRides(const SimulatedRun& truth, const OfflineRun& run, RideScore* score);

struct WalkingSweepCell : RideScore {
  double rate_hz = 0;
  bool gyroscope = true;
  double gap_s = 0;
};

// The error bound of a found ride: 3 % of the true displacement + 0.3 m.
double walkingSweepBound(double displacement_m);

std::vector<WalkingSweepCell> runWalkingSweep(const ElevatorTrackerOptions& options = {});

// A Markdown table: one row per cell, then the totals.
std::string formatWalkingSweep(const std::vector<WalkingSweepCell>& cells);

}  // namespace evermap::elevator
