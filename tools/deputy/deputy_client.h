#pragma once
// The other end of DEPUTY_ORDER / DEPUTY_STATUS, for evermap-deputy-ctl: collects the status
// of the deputies on the network, resolves command and group names against it, sends orders
// and waits until the deputies acknowledge them in their status.
//
// Orders go out repeatedly (every resend_period_s) until a status received after the first
// send shows the desired state, because LCM over UDP may lose a message. Starting a command
// that already "should run" but has ended (failed, or ran to completion) needs the desired
// state to change for the deputy to act (DeputyNode only acts on changes), so start() first
// orders such commands stopped, then started; restart() does so for all its targets.

#include <chrono>
#include <functional>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <string>
#include <vector>

#include <evermap/deputy_order_t.hpp>
#include <evermap/deputy_status_t.hpp>

#include "core/common/expected.h"
#include "core/messages/inbox.h"
#include "core/messages/outbox.h"

namespace evermap::deputy {

struct CtlTarget {
  enum class Kind { kAuto, kCommand, kGroup, kEverything };
  Kind kind = Kind::kAuto;  // kAuto: a command of that name, else a group
  std::string name;
};

struct ProcRef {
  std::string host;
  std::string name;
  bool operator<(const ProcRef& o) const { return host != o.host ? host < o.host : name < o.name; }
  bool operator==(const ProcRef& o) const { return host == o.host && name == o.name; }
};

// Which processes the targets mean in these statuses (one per host). A group matches its
// subgroups too ("pipeline" matches "pipeline/front"). Error when a target matches nothing;
// the message lists what is known.
Expected<std::vector<ProcRef>> resolveTargets(const std::vector<deputy_status_t>& statuses,
                                              const std::vector<CtlTarget>& targets);

// "running", "stopping" (running, desired stopped), "waiting" (restart back-off or start
// delay), "stopped", "failed".
const char* stateText(const deputy_proc_t& p);

// The table evermap-deputy-ctl prints; tab-separated with a header line when `tsv`.
std::string formatStatusTable(const std::vector<deputy_status_t>& statuses, bool tsv);

struct DeputyClientOptions {
  std::string host;         // only this deputy; "" for all
  double timeout_s = 10.0;  // for gathering status and for each acknowledgement
  double settle_s = 1.2;    // after the first status, listen this long for other hosts
  double resend_period_s = 0.5;
  messages::Signer signer;  // this client as a sender, its key (core/messages/key_option.h)

  Status validate() const;
};

class DeputyClient {
 public:
  using Clock = std::chrono::steady_clock;

  // `lcm` must outlive the client. Subscribes to DEPUTY_STATUS.
  DeputyClient(lcm::LCM& lcm, DeputyClientOptions options);
  ~DeputyClient();
  DeputyClient(const DeputyClient&) = delete;
  DeputyClient& operator=(const DeputyClient&) = delete;

  // Replaces the default wait for LCM messages (lcm.handleTimeout) in every loop, e.g. to run
  // a deputy in the same thread in tests.
  void setPump(std::function<void()> pump) { pump_ = std::move(pump); }

  // Latest status of every deputy heard from (error when none answered in time).
  Expected<std::vector<deputy_status_t>> gather();
  Status start(const std::vector<CtlTarget>& targets);
  Status stop(const std::vector<CtlTarget>& targets);
  Status restart(const std::vector<CtlTarget>& targets);
  // Waits until every target is running (or stopped); error after timeout_s.
  Status waitFor(const std::vector<CtlTarget>& targets, bool running);

  const std::map<std::string, deputy_status_t>& latest() const { return latest_; }

 private:
  void onStatus(const deputy_status_t& status);
  void pumpOnce();
  std::vector<deputy_status_t> latestList() const;
  const deputy_proc_t* find(const ProcRef& ref) const;
  // The processes `targets` name among the statuses gathered now.
  Expected<std::vector<ProcRef>> resolve(const std::vector<CtlTarget>& targets);
  // Sends desired state `running` for `refs` until acknowledged.
  Status order(const std::vector<ProcRef>& refs, bool running);

  lcm::LCM& lcm_;
  messages::Outbox out_;
  DeputyClientOptions options_;
  std::function<void()> pump_;
  std::map<std::string, deputy_status_t> latest_;         // by host
  std::map<std::string, Clock::time_point> received_at_;  // by host
  messages::Inbox inbox_;  // DEPUTY_STATUS (wall-clock stamps: no time guard)
};

}  // namespace evermap::deputy
