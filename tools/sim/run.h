#pragma once
// A whole simulated run: the building (or recorded trajectory), the session schedule, and the
// generation of every session's messages. Sessions are planned on demand from their own random
// streams, so memory stays at one session's plan however long the run.
//
// Random streams (random.h) from the run's seed: 1 building, 2 schedule, 1000 + i motion of
// session i, 2000 + i ... sensor noise of session i (session_generator.cpp), 9000 the oracle.

#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/common/expected.h"
#include "tools/sim/sim_options.h"

namespace evermap::sim {

class RunPlan {
 public:
  static Expected<RunPlan> create(const SimOptions& options);

  int sessions() const;
  // Contract: 0 <= index < sessions().
  SessionPlan session(int index) const;
  const Building& building() const { return building_; }
  const SimOptions& options() const { return options_; }
  uint64_t oracleSeed() const { return mixSeed(options_.seed, 9000); }

 private:
  SimOptions options_;
  Building building_;
  std::vector<SessionSlot> slots_;
  std::optional<SessionPlan> recorded_;  // mode = trajectory
};

struct RunSummary {
  std::vector<SessionSummary> sessions;
  std::map<std::string, ChannelCount> channels;

  double durationS() const;
  double distanceM() const;
  int64_t rides() const;
  int64_t voFrames() const;
  int64_t voKeyframes() const;
  int64_t voFailed() const;
  // Median of error / length over VO chains of at least min_length_m (0 when there are none),
  // and how many chains that was.
  double voDriftMedian(double min_length_m, int64_t* chains = nullptr) const;
  std::vector<int> floorsVisited() const;
  int64_t messages() const;
  int64_t bytes() const;
  std::string text() const;  // figures, one per line
};

// Generates every session in order. `sink_for(i)` gives the sink of session i (it may return
// the same sink for all); it is asked once per session, just before the session starts.
RunSummary generateRun(const RunPlan& plan,
                       const std::function<MessageSink&(int session)>& sink_for,
                       const SessionObservers& observers = {});

}  // namespace evermap::sim
