#include "tools/imu-elevator-run/offline_run.h"

namespace evermap::elevator {

OfflineRun runImuElevator(const std::vector<imu::ImuSample>& samples,
                          const imu::AttitudeFilterOptions& attitude_options,
                          const ElevatorTrackerOptions& elevator_options, bool keep_attitudes,
                          std::vector<TraceBin>* trace, std::vector<Pulse>* pulses) {
  imu::AttitudeFilter filter(attitude_options);
  ElevatorTracker tracker(elevator_options);
  tracker.setTrace(trace, pulses);
  OfflineRun out;
  for (const imu::ImuSample& s : samples) {
    const bool used = filter.add(s);
    const imu::Attitude att = filter.initialized() ? filter.attitude() : imu::Attitude{};
    if (used && keep_attitudes) out.attitudes.push_back(att);
    for (FloorEvent& e : tracker.add(s, used ? &att : nullptr)) out.events.push_back(e);
  }
  for (FloorEvent& e : tracker.finish()) out.events.push_back(e);
  out.rides = tracker.rides();
  out.rejected = tracker.rejected();
  out.gravity_m_s2 = tracker.gravityReference();
  out.gravity_plausible = tracker.gravityPlausible();
  out.abandoned = tracker.abandoned();
  out.floor_heights = tracker.floors().heights();
  out.counts = tracker.counts();
  out.gate = tracker.gateCounts();
  out.attitude_counts = filter.counts();
  return out;
}

std::vector<FloorEvent> OfflineRun::eventsOf(FloorEvent::Kind a, FloorEvent::Kind b) const {
  std::vector<FloorEvent> out;
  for (const FloorEvent& e : events)
    if (e.kind == a || e.kind == b) out.push_back(e);
  return out;
}

}  // namespace evermap::elevator
