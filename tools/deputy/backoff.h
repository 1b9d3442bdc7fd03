#pragma once
// When to restart a process that keeps ending: exponential back-off, as bot-procman's deputy
// throttles respawns, reset once a run has lasted long enough to count as stable.
//
// The n-th consecutive short run is followed by a wait of
//   min(max_delay_ms, initial_delay_ms * factor^(n-1)),
// and a run that lasted at least stable_after_s starts the count again at 1. Durations are
// given by the caller (wall-clock supervision time), so the policy itself is a pure function
// of the runs it is told about.

#include <string>

#include "core/common/expected.h"
#include "core/common/option_fields.h"

namespace evermap::deputy {

struct BackoffOptions {
  double initial_delay_ms = 250.0;
  double factor = 2.0;
  double max_delay_ms = 16000.0;
  double stable_after_s = 10.0;

  void declareOptions(OptionList& o);
  Status validate() const;       // the ranges, and max_delay_ms >= initial_delay_ms
  std::string describe() const;  // "backoff 250 ms x2 up to 16000 ms, stable after 10 s"
};

class RespawnBackoff {
 public:
  explicit RespawnBackoff(BackoffOptions options = {}) : options_(options) {}

  // A run of `run_duration_s` seconds has ended; returns the wait before the restart, ms.
  double onExit(double run_duration_s);
  // Forget the history (after an explicit stop or start order).
  void reset() { consecutive_short_runs_ = 0; }
  int consecutiveShortRuns() const { return consecutive_short_runs_; }

 private:
  BackoffOptions options_;
  int consecutive_short_runs_ = 0;
};

}  // namespace evermap::deputy
