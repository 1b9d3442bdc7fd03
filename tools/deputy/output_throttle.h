#pragma once
// Batching and rate limiting of the output lines a deputy publishes (DEPUTY_OUTPUT).
//
// The log files get every byte; the network gets at most a bounded rate per process, so a
// process that floods its output cannot flood the LCM network. Lines of one process are
// collected for flush_interval_ms (or until max_message_bytes) and sent as one message. A
// token bucket per process (max_bytes_per_s, burst_bytes) decides whether a line is sent;
// lines over the rate are dropped and counted, and the next message says how many.
//
// Time is passed in by the caller (the deputy's wall clock), so the policy is testable.

#include <chrono>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "core/common/expected.h"
#include "core/common/option_fields.h"

namespace evermap::deputy {

struct OutputThrottleOptions {
  double flush_interval_ms = 100.0;
  size_t max_message_bytes = 8192;
  double max_bytes_per_s = 32768.0;
  double burst_bytes = 65536.0;

  void declareOptions(OptionList& o);
  Status validate() const;  // the ranges, and burst_bytes >= max_message_bytes
};

class OutputThrottle {
 public:
  using Clock = std::chrono::steady_clock;

  struct Batch {
    std::string name;  // the process
    std::string text;  // whole lines, each ending in '\n'
  };

  explicit OutputThrottle(OutputThrottleOptions options = {}) : options_(options) {}

  // One line of process `name` (without its '\n').
  void addLine(const std::string& name, const std::string& line, Clock::time_point now);
  // Batches due at `now` (all pending ones when `flush_all`).
  std::vector<Batch> takeDue(Clock::time_point now, bool flush_all = false);
  // When the oldest pending line becomes due; Clock::time_point::max() when none waits.
  Clock::time_point nextDue() const;
  int64_t droppedLines() const { return dropped_total_; }

 private:
  struct Stream {
    std::string pending;
    Clock::time_point first_pending{};
    double tokens = 0.0;
    Clock::time_point last_refill{};
    bool initialised = false;
    int64_t dropped_since_sent = 0;
  };
  OutputThrottleOptions options_;
  std::map<std::string, Stream> streams_;
  int64_t dropped_total_ = 0;
};

}  // namespace evermap::deputy
