#pragma once
// What a receiver makes of a message's envelope (envelope.h), before the message is decoded
// (issue 47). The Inbox runs it first on every message.
//
// Identity (always): each channel is locked onto one sender, the first whose message arrives;
// messages on it from any other sender are ignored and counted, with one line per new sender.
// The lock passes to another sender when the locked one has sent nothing (on any channel of
// this receiver) for `silence_s` of wall time: a process the deputy restarted is a new instance
// and is taken then. Messages without an envelope are one sender, "anonymous". Channels where
// many senders are the rule (INPUT_STATS, the deputy's) are shared: no lock.
//
// Key (when the process has one): a message without an envelope, without a mac or with a wrong
// one is refused ("unauthenticated"). A message that is authentic but replayed is refused
// ("replayed"): its counter must be above the last one seen from its sender instance on its
// channel, and its sender's wall clock within `replay_window_s` of ours — the window bounds
// what a receiver that restarted (and forgot the counters) can be fed again.
//
// Threading: not thread-safe (the Inbox's thread).

#include <chrono>
#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <utility>

#include "core/common/expected.h"
#include "core/messages/envelope.h"

namespace evermap::messages {

struct SenderCheckOptions {
  // With a key, seconds between the sender's wall clock (in the envelope) and ours beyond which
  // a message is refused as replayed: covers LCM queueing behind a busy receiver (seconds) and
  // the clock offset between hosts kept by NTP (milliseconds); an attacker who recorded the
  // traffic can replay it only within it, and only to a receiver that restarted since.
  double replay_window_s = 30.0;
  // Seconds of wall time a channel's sender may be silent before another sender may take the
  // channel: above the gaps of a live stream (a frame, an IMU sample: milliseconds), below a
  // deputy restart's delay plus start-up (a few seconds).
  double silence_s = 2.0;

  Status validate() const;
};

class SenderCheck {
 public:
  enum class Kind { kAccept, kMalformed, kUnauthenticated, kReplayed, kOtherSender };
  struct Result {
    Kind kind = Kind::kAccept;
    int64_t message_size = 0;  // the LCM message's bytes, without the envelope
    std::string why;           // for a refusal: one line naming channel and reason
    std::string note;          // a line to log now (a new sender ignored, a lock taken over)
  };
  struct Now {
    std::chrono::steady_clock::time_point steady;
    int64_t wall_utime = 0;
    static Now read();
  };

  // Without `key`: identity only. `key` must outlive the check.
  SenderCheck(const MacKey* key, SenderCheckOptions options);

  void shareChannel(const std::string& channel) { shared_.insert(channel); }
  Result check(const std::string& channel, const void* data, int64_t size, Now now);
  // The sender `channel` is locked onto, if any.
  std::optional<SenderId> lockedSender(const std::string& channel) const;

 private:
  struct Lock {
    SenderId who;
    std::chrono::steady_clock::time_point last;
    SenderId last_ignored;
    bool ignored_any = false;
  };
  Result authenticate(const std::string& channel, const Expected<Opened>& opened, Now now);
  Result lockOnto(const std::string& channel, const SenderId& sender, Now now);

  const MacKey* key_;
  SenderCheckOptions o_;
  std::set<std::string> shared_;
  std::map<std::string, Lock> locks_;
  struct Seen {
    uint64_t counter;
    int64_t wall_utime;
  };
  std::map<std::pair<uint64_t, std::string>, Seen> seen_;  // (instance, channel)
};

}  // namespace evermap::messages
