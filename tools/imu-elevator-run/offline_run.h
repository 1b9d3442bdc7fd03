#pragma once
// The two filters chained in one process, as the offline runner, the tests and benchmarks
// use them: each IMU sample goes through the attitude filter, then with the attitude it
// produced into the elevator tracker. Deterministic: same samples, same result. At the end of
// the samples the tracker is finished (ElevatorTracker::finish: a stop in the last seconds
// still ends its ride).

#include <vector>

#include "elevator-proc/elevator_tracker.h"
#include "imu-proc/attitude_filter.h"

namespace evermap::elevator {

struct OfflineRun {
  std::vector<Ride> rides;
  std::vector<AbandonedRide> abandoned;
  std::vector<RejectedRide> rejected;
  double gravity_m_s2 = 0;  // the tracker's reference at the end
  bool gravity_plausible = true;
  std::vector<FloorEvent> events;  // ride starts and ends, and the vertical watch's
  // ... only the rides' starts and ends, or only the watch's
  std::vector<FloorEvent> rideEvents() const {
    return eventsOf(FloorEvent::Kind::kRideStart, FloorEvent::Kind::kRideEnd);
  }
  std::vector<FloorEvent> watchEvents() const {
    return eventsOf(FloorEvent::Kind::kVerticalMotion, FloorEvent::Kind::kVerticalStill);
  }
  std::vector<FloorEvent> eventsOf(FloorEvent::Kind a, FloorEvent::Kind b) const;
  std::vector<double> floor_heights;
  ElevatorCounts counts;
  imu::SampleGateCounts gate;
  imu::AttitudeFilterCounts attitude_counts;
  std::vector<imu::Attitude> attitudes;  // only when keep_attitudes
};

OfflineRun runImuElevator(const std::vector<imu::ImuSample>& samples,
                          const imu::AttitudeFilterOptions& attitude_options,
                          const ElevatorTrackerOptions& elevator_options,
                          bool keep_attitudes = false, std::vector<TraceBin>* trace = nullptr,
                          std::vector<Pulse>* pulses = nullptr);

}  // namespace evermap::elevator
