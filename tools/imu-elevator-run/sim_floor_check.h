#pragma once
// imu-proc and elevator-proc on the measurement-level simulator's raw IMU (tools/sim): every
// elevator ride of a simulated run must end on the right floor.
//
// The simulator publishes IMU (specific force with gravity, body rates, a per-session
// accelerometer bias, white noise) only around elevator rides: from imu.margin_s before the
// cab starts to imu.margin_s after it stops. Each session is generated (session_generator.h)
// and its IMU messages, decoded from the bytes LCM would carry, are fed in time order
// through one AttitudeFilter and one ElevatorTracker that live for the whole run, so the
// floor table is built up as rides happen, across sessions, exactly as elevator-proc would
// (the long gaps between IMU windows restart the tracker's grid; its floor table stays).
//
// Scoring. The floor table's heights are relative to the floor the run starts on (the
// building's main floor, where every session starts and ends). A table floor is mapped to
// the simulated floor nearest to main-floor height + table height (Building::nearestFloor),
// when it is first reached. A true ride is matched to the reported ride that overlaps it in
// time; it "ends on the right floor" when the reported arrival floor maps to the true
// arrival floor. Reported rides overlapping no true ride are spurious. The vertical watch's
// alarm (EVENT_VERTICAL_MOTION) belongs to the true ride whose cab is moving at it (or starts
// within a second after it); its latency is from the cab's start. Other alarms are false.

#include <cstdint>
#include <string>
#include <vector>

#include "core/common/expected.h"
#include "elevator-proc/elevator_tracker.h"
#include "imu-proc/attitude_filter.h"
#include "tools/sim/sim_options.h"

namespace evermap::elevator {

struct SimRideCheck {
  int session = 0;
  int64_t start_utime = 0;  // the true ride (cab moving)
  int64_t end_utime = 0;
  int floor_from = 0;  // simulated floors
  int floor_to = 0;
  double true_dz_m = 0;
  bool found = false;         // a reported ride overlaps it
  double displacement_m = 0;  // of that ride
  int table_floor = -1;       // its arrival floor in elevator-proc's table
  int mapped_floor = -1;      // the simulated floor that table floor maps to
  bool right_floor = false;
  double alarm_latency_s = -1;  // the watch's first alarm after the cab started (-1: none)
};

struct SimFloorCheck {
  std::vector<SimRideCheck> rides;
  int spurious = 0;                      // reported rides over no true ride
  int false_alarms = 0;                  // vertical-motion alarms during no true ride
  std::vector<AbandonedRide> abandoned;  // ride starts given up (not rides; for the record)
  int sessions = 0;
  int64_t imu_samples = 0;
  std::vector<int> floors_visited;    // simulated floors reached by the true rides
  std::vector<double> table_heights;  // elevator-proc's floor table at the end
  ElevatorCounts counts;

  int found() const;           // rides found
  int correct() const;         // rides found and on the right floor
  double worstErrorM() const;  // largest |displacement - true| over found rides
  std::string table() const;   // one line per ride
  std::string summary() const;
};

// Generates the run's sessions (at most max_sessions; <= 0: all) and checks every ride.
// Errors: options that do not validate, a trajectory-mode run (no elevator), no IMU enabled.
Expected<SimFloorCheck> checkSimulatedFloors(const sim::SimOptions& options,
                                             const imu::AttitudeFilterOptions& attitude_options,
                                             const ElevatorTrackerOptions& elevator_options,
                                             int max_sessions = 0);

}  // namespace evermap::elevator
