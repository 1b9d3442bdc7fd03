#pragma once
// The patrol planner: hours of robot motion through a building, as the paper's data set was
// collected (section V): many sessions spread over months, repeated excursions through one
// main floor and occasional elevator trips to the other floors.
//
// A session starts and ends at the building's home place on the main floor. It is a chain of
// patrols: drive to a few random goal places along shortest paths (turning in place at
// places, pausing at goals). Early sessions only reach the part of the main floor nearest to
// home, a growing share each session, so the map keeps growing for a while as in the paper's
// Fig. 7. Each other floor is visited at least once over the run; more visits happen at random.
// With explore_tours, the building is explored in the first explore_sessions sessions the way
// a robot is driven around a new building: each of those sessions starts with a tour of the
// part of the main floor open to it, and each other floor's first visit (scheduled in
// sessions 1 .. explore_sessions - 1) is a tour of that floor; a tour drives every passage
// once in each direction (an Euler circuit of the doubled passage graph), so every place has
// been seen from both ways along every corridor before the later patrols.
// An elevator trip: wait at the lobby, drive into the cab, turn to face the door, wait for the
// door, ride (sometimes with an intermediate stop: the robot does not choose where the cab
// stops, section IV-F), wait, drive out.

#include <cstdint>
#include <memory>
#include <vector>

#include "core/common/expected.h"
#include "tools/sim/building.h"
#include "tools/sim/motion.h"

namespace evermap::sim {

struct PatrolOptions {
  int sessions = 14;
  double total_hours = 9.0;                // summed over sessions
  double session_jitter = 0.3;             // each session lasts mean * (1 ± jitter), then rescaled
  double span_days = 180.0;                // the sessions are spread over this many days
  int64_t start_utime = 1325419200000000;  // 2012-01-01 12:00 UTC, start of session 0
  double drive_speed_mps = 0.55;           // cruise speed (each leg draws ±15 %)
  double drive_accel_mps2 = 0.5;
  double turn_rate_radps = 0.8;
  double turn_accel_radps2 = 1.5;
  double pause_min_s = 1.0;  // at each goal
  double pause_max_s = 15.0;
  int goals_min = 3;  // per patrol
  int goals_max = 8;
  double other_floor_probability = 0.08;  // per patrol, beyond the visits that cover every floor
  int explore_sessions = 4;               // the whole main floor is reachable from this session on
  bool explore_tours = false;             // tours of the main floor and first visits (see above)
  double roughness_rad = 0.005;           // amplitude of floor-induced roll and pitch

  Status validate() const;
};

struct ElevatorOptions {
  double accel_min_mps2 = 0.5;  // peak acceleration of a ride, drawn per ride
  double accel_max_mps2 = 1.0;
  double speed_min_mps = 1.0;  // cruise speed, drawn per ride
  double speed_max_mps = 2.0;
  double call_wait_max_s = 30.0;  // waiting at the lobby for the cab
  double door_wait_min_s = 4.0;   // standing in the cab before and after each ride
  double door_wait_max_s = 10.0;
  double intermediate_stop_probability = 0.25;
  double stop_dwell_min_s = 5.0;
  double stop_dwell_max_s = 15.0;

  Status validate() const;
};

// One movement of the cab between two stops.
struct ElevatorRide {
  int64_t start_utime = 0;  // the cab starts moving
  int64_t end_utime = 0;    // the cab has stopped
  int floor_from = 0;
  int floor_to = 0;
  double z_from = 0.0;
  double z_to = 0.0;
};

struct SessionPlan {
  int index = 0;
  std::shared_ptr<const Trajectory> trajectory;
  std::vector<ElevatorRide> rides;
  double distance_m = 0.0;
  std::vector<int> floors_visited;  // sorted
};

// Start time and length of every session, and the floors each must visit.
struct SessionSlot {
  int64_t start_utime = 0;
  double duration_s = 0.0;
  std::vector<int> must_visit;
};
std::vector<SessionSlot> scheduleSessions(const Building& building, const PatrolOptions& options,
                                          Random& rng);

// Plans one session; `rng` is that session's own stream.
SessionPlan planSession(const Building& building, const PatrolOptions& patrol,
                        const ElevatorOptions& elevator, int index, const SessionSlot& slot,
                        Random& rng);

}  // namespace evermap::sim
