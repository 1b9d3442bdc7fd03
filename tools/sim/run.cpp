#include "tools/sim/run.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <set>
#include <sstream>

#include "tools/sim/kitti_trajectory.h"

namespace evermap::sim {

Expected<RunPlan> RunPlan::create(const SimOptions& options) {
  if (auto s = options.validate(); !s) return s.error();
  RunPlan plan;
  plan.options_ = options;
  if (options.mode == SimOptions::Mode::kTrajectory) {
    auto recorded =
        loadKittiSession(options.trajectory, options.sensors.camera, options.patrol.start_utime);
    if (!recorded) return recorded.error();
    plan.building_ = flatBuilding();
    plan.recorded_ = std::move(*recorded);
    return plan;
  }
  Random building_rng = Random::derive(options.seed, 1);
  plan.building_ = generateBuilding(options.building, building_rng);
  Random schedule_rng = Random::derive(options.seed, 2);
  plan.slots_ = scheduleSessions(plan.building_, options.patrol, schedule_rng);
  return plan;
}

int RunPlan::sessions() const { return recorded_ ? 1 : static_cast<int>(slots_.size()); }

SessionPlan RunPlan::session(int index) const {
  if (index < 0 || index >= sessions()) {
    std::fprintf(stderr, "evermap::sim: session %d of a %d-session run\n", index, sessions());
    std::abort();
  }
  if (recorded_) return *recorded_;
  Random rng = Random::derive(options_.seed, 1000 + static_cast<uint64_t>(index));
  return planSession(building_, options_.patrol, options_.elevator, index, slots_[index], rng);
}

namespace {

// The sum of `value` over the sessions, in their order.
template <class T, class Value>
T sumSessions(const std::vector<SessionSummary>& sessions, Value value) {
  T s = 0;
  for (const auto& x : sessions) s += value(x);
  return s;
}

}  // namespace

double RunSummary::durationS() const {
  return sumSessions<double>(sessions, [](const SessionSummary& x) { return x.durationS(); });
}
double RunSummary::distanceM() const {
  return sumSessions<double>(sessions, [](const SessionSummary& x) { return x.distance_m; });
}
int64_t RunSummary::rides() const {
  return sumSessions<int64_t>(sessions, [](const SessionSummary& x) { return x.rides; });
}
int64_t RunSummary::voFrames() const {
  return sumSessions<int64_t>(sessions, [](const SessionSummary& x) { return x.vo_frames; });
}
int64_t RunSummary::voKeyframes() const {
  return sumSessions<int64_t>(sessions, [](const SessionSummary& x) { return x.vo_keyframes; });
}
int64_t RunSummary::voFailed() const {
  return sumSessions<int64_t>(sessions, [](const SessionSummary& x) { return x.voFailed(); });
}
double RunSummary::voDriftMedian(double min_length_m, int64_t* chains) const {
  std::vector<double> ratios;
  for (const auto& x : sessions) {
    for (const VoChain& c : x.vo_chains) {
      if (c.length_m >= min_length_m && c.length_m > 0.0) ratios.push_back(c.error_m / c.length_m);
    }
  }
  if (chains) *chains = static_cast<int64_t>(ratios.size());
  if (ratios.empty()) return 0.0;
  std::nth_element(ratios.begin(), ratios.begin() + ratios.size() / 2, ratios.end());
  return ratios[ratios.size() / 2];
}

std::vector<int> RunSummary::floorsVisited() const {
  std::set<int> all;
  for (const auto& x : sessions) all.insert(x.floors_visited.begin(), x.floors_visited.end());
  return {all.begin(), all.end()};
}
int64_t RunSummary::messages() const {
  int64_t s = 0;
  for (const auto& [name, c] : channels) s += c.messages;
  return s;
}
int64_t RunSummary::bytes() const {
  int64_t s = 0;
  for (const auto& [name, c] : channels) s += c.bytes;
  return s;
}

std::string RunSummary::text() const {
  std::ostringstream o;
  char line[256];
  // One "label  value" row, the value from `format` (one number) at column 29.
  const auto row = [&](const char* label, const char* format, auto value) {
    char text[64];
    std::snprintf(text, sizeof text, format, value);
    std::snprintf(line, sizeof line, "%-28s%s\n", label, text);
    o << line;
  };
  row("sessions", "%zu", sessions.size());
  row("simulated time", "%.2f h", durationS() / 3600.0);
  row("distance driven", "%.2f km", distanceM() / 1000.0);
  row("floors visited", "%zu", floorsVisited().size());
  row("elevator rides", "%lld", static_cast<long long>(rides()));
  row("VO frames", "%lld", static_cast<long long>(voFrames()));
  row("VO keyframes", "%lld", static_cast<long long>(voKeyframes()));
  row("failed VO frames", "%lld", static_cast<long long>(voFailed()));
  int64_t chains = 0;
  const double drift = voDriftMedian(20.0, &chains);
  std::snprintf(line, sizeof line,
                "VO drift, chains >= 20 m   %.2f %% of distance (median of %lld)\n", 100.0 * drift,
                static_cast<long long>(chains));
  o << line;
  o << "channel              messages          bytes\n";
  for (const auto& [name, c] : channels) {
    std::snprintf(line, sizeof line, "%-20s %8lld %14lld\n", name.c_str(),
                  static_cast<long long>(c.messages), static_cast<long long>(c.bytes));
    o << line;
  }
  std::snprintf(line, sizeof line, "%-20s %8lld %14lld\n", "total",
                static_cast<long long>(messages()), static_cast<long long>(bytes()));
  o << line;
  return o.str();
}

RunSummary generateRun(const RunPlan& plan, const std::function<MessageSink&(int)>& sink_for,
                       const SessionObservers& observers) {
  RunSummary summary;
  for (int i = 0; i < plan.sessions(); ++i) {
    const SessionPlan session = plan.session(i);
    CountingSink counter(&sink_for(i));
    summary.sessions.push_back(generateSession(plan.building(), session, plan.options().sensors,
                                               plan.options().seed, counter, observers));
    for (const auto& [name, c] : counter.counts()) {
      summary.channels[name].messages += c.messages;
      summary.channels[name].bytes += c.bytes;
    }
  }
  return summary;
}

}  // namespace evermap::sim
