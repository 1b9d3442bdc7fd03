#include "core/messages/convert.h"
#include "tools/imu-elevator-run/sim_floor_check.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>

#include <evermap/imu_t.hpp>

#include "core/imu/lcm_convert.h"
#include "core/messages/channels.h"
#include "tools/sim/message_sink.h"
#include "tools/sim/run.h"

namespace evermap::elevator {

namespace {

// Feeds the IMU messages of the simulator straight into the two filters, in the order the
// simulator emits them (time order), as elevator-proc would receive them over LCM.
class ImuFeed final : public sim::MessageSink {
 public:
  ImuFeed(imu::AttitudeFilter& filter, ElevatorTracker& tracker)
      : filter_(filter), tracker_(tracker) {}
  void write(const std::string& channel, int64_t, const std::vector<uint8_t>& data) override {
    if (channel != channels::kImu) return;
    auto m = messages::decodeLcm<imu_t>(data.data(), static_cast<int64_t>(data.size()), channel);
    if (!m) {
      ++undecodable;
      return;
    }
    const imu::ImuSample s = imu::fromLcm(*m);
    ++samples;
    const bool used = filter_.add(s);
    const imu::Attitude att = filter_.initialized() ? filter_.attitude() : imu::Attitude{};
    keep(tracker_.add(s, used ? &att : nullptr));
  }
  void keep(const std::vector<FloorEvent>& events) {
    for (const FloorEvent& e : events)
      if (e.kind == FloorEvent::Kind::kVerticalMotion) alarms.push_back(e.utime);
  }
  std::vector<int64_t> alarms;  // the watch's vertical-motion alarms
  int64_t samples = 0;
  int64_t undecodable = 0;

 private:
  imu::AttitudeFilter& filter_;
  ElevatorTracker& tracker_;
};

double seconds(int64_t utime) { return 1e-6 * static_cast<double>(utime); }

// The true ride t and the reported ride overlapping it, if any (marked used).
SimRideCheck matchRide(int session, const sim::ElevatorRide& t, const std::vector<Ride>& rides,
                       std::vector<bool>* used) {
  SimRideCheck c;
  c.session = session;
  c.start_utime = t.start_utime;
  c.end_utime = t.end_utime;
  c.floor_from = t.floor_from;
  c.floor_to = t.floor_to;
  c.true_dz_m = t.z_to - t.z_from;
  for (size_t k = 0; k < rides.size(); ++k) {
    const Ride& r = rides[k];
    if (r.start_utime < t.end_utime && r.end_utime > t.start_utime) {
      c.found = true;
      (*used)[k] = true;
      c.displacement_m = r.displacement_m;
      c.table_floor = r.to_floor;
    }
  }
  return c;
}

// Each alarm to the true ride whose cab moves at it (or starts within 1 s after it).
void scoreAlarms(const std::vector<int64_t>& alarms, SimFloorCheck* out) {
  for (const int64_t a : alarms) {
    bool in_ride = false;
    for (SimRideCheck& c : out->rides) {
      if (a < c.start_utime - 1'000'000 || a > c.end_utime) continue;
      in_ride = true;
      if (c.alarm_latency_s < 0) c.alarm_latency_s = seconds(a - c.start_utime);
    }
    if (!in_ride) ++out->false_alarms;
  }
}

}  // namespace

int SimFloorCheck::found() const {
  return static_cast<int>(
      std::count_if(rides.begin(), rides.end(), [](const SimRideCheck& r) { return r.found; }));
}

int SimFloorCheck::correct() const {
  return static_cast<int>(std::count_if(rides.begin(), rides.end(),
                                        [](const SimRideCheck& r) { return r.right_floor; }));
}

double SimFloorCheck::worstErrorM() const {
  double worst = 0;
  for (const SimRideCheck& r : rides) {
    if (r.found) worst = std::max(worst, std::abs(r.displacement_m - r.true_dz_m));
  }
  return worst;
}

std::string SimFloorCheck::table() const {
  std::string out =
      "  session  start_s   dur_s  floors   true_m  found_m  table  -> sim  ok  alarm_s\n";
  const int64_t origin = rides.empty() ? 0 : rides.front().start_utime;
  for (const SimRideCheck& r : rides) {
    char line[200];
    if (r.found) {
      std::snprintf(line, sizeof line,
                    "  %7d %8.1f %7.1f  %2d->%-2d %+8.2f %+8.2f  %5d  %4d  %-3s %7.1f\n", r.session,
                    seconds(r.start_utime - origin), seconds(r.end_utime - r.start_utime),
                    r.floor_from, r.floor_to, r.true_dz_m, r.displacement_m, r.table_floor,
                    r.mapped_floor, r.right_floor ? "yes" : "NO", r.alarm_latency_s);
    } else {
      std::snprintf(line, sizeof line, "  %7d %8.1f %7.1f  %2d->%-2d %+8.2f   missed\n", r.session,
                    seconds(r.start_utime - origin), seconds(r.end_utime - r.start_utime),
                    r.floor_from, r.floor_to, r.true_dz_m);
    }
    out += line;
  }
  for (const AbandonedRide& a : abandoned) {
    char line[200];
    std::snprintf(line, sizeof line, "  abandoned ride start at %.1f s: %s\n",
                  seconds(a.start_utime - origin), a.reason.c_str());
    out += line;
  }
  return out;
}

std::string SimFloorCheck::summary() const {
  std::vector<double> latency;
  for (const SimRideCheck& r : rides)
    if (r.alarm_latency_s >= 0) latency.push_back(r.alarm_latency_s);
  std::sort(latency.begin(), latency.end());
  char buf[600];
  std::snprintf(
      buf, sizeof buf,
      "%d sessions, %lld IMU samples, %zu floors visited, %zu rides: %d found, %d on the right "
      "floor; "
      "%d spurious, %d abandoned starts; worst displacement error %.2f m; table has %zu floors; "
      "vertical alarms: %zu rides alarmed, latency median %.1f s, max %.1f s, %d false",
      sessions, static_cast<long long>(imu_samples), floors_visited.size(), rides.size(), found(),
      correct(), spurious, static_cast<int>(abandoned.size()), worstErrorM(), table_heights.size(),
      latency.size(), latency.empty() ? -1.0 : latency[latency.size() / 2],
      latency.empty() ? -1.0 : latency.back(), false_alarms);
  return buf;
}

Expected<SimFloorCheck> checkSimulatedFloors(const sim::SimOptions& options,
                                             const imu::AttitudeFilterOptions& attitude_options,
                                             const ElevatorTrackerOptions& elevator_options,
                                             int max_sessions) {
  if (options.mode != sim::SimOptions::Mode::kBuilding) {
    return Error{
        "simulator options: mode must be building (a recorded trajectory has no elevator)"};
  }
  if (!options.sensors.imu.enabled)
    return Error{"simulator options: imu.enabled is 0 (no IMU to check)"};
  if (auto s = attitude_options.validate(); !s) return s.error();
  if (auto s = elevator_options.validate(); !s) return s.error();
  // Only the IMU is used. The other streams are thinned to save time; every sensor draws from
  // its own random stream (session_generator.cpp), so the IMU samples are unchanged by this.
  sim::SimOptions o = options;
  o.sensors.vo.rate_hz = 0.1;
  o.sensors.wheel.rate_hz = 0.1;
  o.sensors.attitude.rate_hz = 0.1;
  o.sensors.ground_truth_rate_hz = 0.1;
  auto plan = sim::RunPlan::create(o);
  if (!plan) return plan.error();
  const sim::Building& building = plan->building();
  const double main_z = building.floors[building.main_floor].height_m;

  imu::AttitudeFilter filter(attitude_options);
  ElevatorTracker tracker(elevator_options);
  ImuFeed feed(filter, tracker);
  SimFloorCheck out;
  std::vector<std::pair<int, sim::ElevatorRide>> truth;
  std::set<int> visited{building.main_floor};
  const int n = max_sessions > 0 ? std::min(max_sessions, plan->sessions()) : plan->sessions();
  for (int i = 0; i < n; ++i) {
    const sim::SessionPlan session = plan->session(i);
    sim::generateSession(building, session, o.sensors, o.seed, feed);
    for (const sim::ElevatorRide& r : session.rides) {
      truth.emplace_back(i, r);
      visited.insert(r.floor_to);
    }
    ++out.sessions;
  }
  feed.keep(tracker.finish());
  if (feed.undecodable > 0) return Error{"simulator: undecodable IMU messages"};

  // Table floor -> simulated floor, fixed when the table floor is first reached.
  std::map<int, int> to_sim{{0, building.main_floor}};
  const std::vector<double>& heights = tracker.floors().heights();
  std::vector<bool> used(tracker.rides().size(), false);
  for (const auto& [session, t] : truth) {
    SimRideCheck c = matchRide(session, t, tracker.rides(), &used);
    if (c.found) {
      auto it = to_sim.find(c.table_floor);
      if (it == to_sim.end()) {
        it = to_sim.emplace(c.table_floor, building.nearestFloor(main_z + heights[c.table_floor]))
                 .first;
      }
      c.mapped_floor = it->second;
      c.right_floor = c.mapped_floor == c.floor_to;
    }
    out.rides.push_back(c);
  }
  scoreAlarms(feed.alarms, &out);
  out.spurious = static_cast<int>(std::count(used.begin(), used.end(), false));
  out.abandoned = tracker.abandoned();
  out.imu_samples = feed.samples;
  out.floors_visited.assign(visited.begin(), visited.end());
  out.table_heights = heights;
  out.counts = tracker.counts();
  return out;
}

}  // namespace evermap::elevator
