#pragma once
// The deputy on LCM, as bot-procman's deputy: publishes DEPUTY_STATUS (deputy_status_t) at
// 1 Hz and whenever a process changes state, publishes output lines on DEPUTY_OUTPUT
// (deputy_output_t, batched and rate-limited by OutputThrottle), and obeys DEPUTY_ORDER
// (deputy_order_t) addressed to its host name or to "" (every deputy).
//
// An order lists desired states by process name. A name this deputy does not supervise is
// ignored (it may be another deputy's). Only changes act (Supervisor::setDesired), so an order
// sent repeatedly, as procman's sheriff does, starts nothing twice.
//
// Threading: one thread runs spinOnce() and owns the LCM object's handling.

#include <chrono>
#include <cstdint>
#include <lcm/lcm-cpp.hpp>

#include "core/messages/inbox.h"
#include "core/messages/outbox.h"
#include <optional>
#include <string>

#include <evermap/deputy_order_t.hpp>
#include <evermap/deputy_status_t.hpp>

#include "core/common/expected.h"
#include "tools/deputy/output_throttle.h"
#include "tools/deputy/script_runner.h"
#include "tools/deputy/supervisor.h"

namespace evermap::deputy {

struct DeputyNodeOptions {
  std::string host;               // this deputy's name in orders and status
  double status_period_s = 1.0;   // DEPUTY_STATUS period (CPU % is measured over it)
  double min_status_gap_s = 0.1;  // extra status messages on changes, at most this often
  bool publish_output = true;     // DEPUTY_OUTPUT on/off (log files are always written)
  OutputThrottleOptions output;
  bool print_notes = false;  // the deputy's notes ("started pid 12") also on stderr
  messages::Signer signer;   // this deputy as a sender, its key (core/messages/key_option.h)

  Status validate() const;
};

// The message value of a state (deputy_proc_t::STATE_*).
int8_t messageState(ProcessState state);

class DeputyNode {
 public:
  using Clock = std::chrono::steady_clock;

  struct Counters {
    int64_t orders_applied = 0;     // orders addressed to this deputy
    int64_t orders_for_others = 0;  // addressed to another host
    int64_t unknown_names = 0;      // names in our orders we do not supervise
    int64_t orders_malformed = 0;   // did not decode, or values out of range
    int64_t handler_failed = 0;     // an order's handling threw (caught at the boundary)
    int64_t status_published = 0;
    int64_t output_published = 0;
  };

  // `lcm` and `supervisor` must outlive the node. Subscribes to DEPUTY_ORDER.
  DeputyNode(lcm::LCM& lcm, Supervisor& supervisor, DeputyNodeOptions options);
  ~DeputyNode();
  DeputyNode(const DeputyNode&) = delete;
  DeputyNode& operator=(const DeputyNode&) = delete;

  // Runs a script of `config` (which must outlive it) alongside the orders.
  void runScript(ScriptRunner runner);
  bool scriptRunning() const { return script_.has_value(); }

  // Waits up to max_wait_ms for an event (an LCM message, child output or end, a deadline,
  // or `extra_fd` readable, e.g. a signalfd), then handles what is due.
  void spinOnce(int max_wait_ms, int extra_fd = -1);
  // Publishes DEPUTY_STATUS now (and any pending output).
  void publishStatus();
  void flushOutput();
  // The status message as it would be published now.
  deputy_status_t makeStatus() const;
  Counters counters() const;
  const messages::Inbox& inbox() const { return inbox_; }
  int64_t outputLinesDropped() const { return throttle_.droppedLines(); }

 private:
  Status onOrder(const deputy_order_t& order);
  void onLine(const std::string& name, const std::string& line, bool from_deputy);
  std::string stateSignature() const;
  void publishOutput(bool all);

  lcm::LCM& lcm_;
  messages::Outbox out_;
  Supervisor& supervisor_;
  DeputyNodeOptions options_;
  OutputThrottle throttle_;
  std::optional<ScriptRunner> script_;
  Clock::time_point next_status_{};
  Clock::time_point last_status_{};
  std::string last_signature_;
  bool change_pending_ = false;  // a state changed too soon after the last status
  Counters counters_;
  // DEPUTY_ORDER through the one decoding path (a 24-byte order with a string length of 0 made
  // the deputy abort: its children ran on unsupervised). Orders carry the sender's wall clock:
  // no time guard.
  messages::Inbox inbox_;
};

// Microseconds since the epoch (message utime of the deputy's own messages).
int64_t wallClockUtime();

}  // namespace evermap::deputy
