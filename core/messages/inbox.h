#pragma once
// The LCM input boundary of a process (DESIGN.md section 2, "every receiver validates lengths,
// finiteness and ranges before use and counts what it drops"). Every subscription made through
// an Inbox:
//  - has a bounded LCM queue (no subscription keeps LCM's silent default by accident);
//  - is checked along its type's wire layout and decoded by decodeLcm, the one decoding path
//    (convert.h): no length a message claims is allocated before its bytes are seen;
//  - checks the sender's envelope first (sender_check.h: one sender per channel; with a key,
//    only authentic messages, none replayed) and strips it;
//  - passes the message time guard (TimeGuard below) when the process enables it;
//  - calls the handler inside a try: an exception is caught here, logged and counted;
//  - counts per channel what was received, malformed, refused by the guard or the handler,
//    and what failed (threw). The first lines of each kind are logged, then one in 1000.
// Threading: handlers run inside lcm.handle() on the caller's thread, as LCM's own do; the
// Inbox is not thread-safe.

#include <chrono>
#include <cstdint>
#include <deque>
#include <functional>
#include <list>
#include <map>
#include <string>
#include <type_traits>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include <evermap/input_stats_t.hpp>

#include "core/common/expected.h"
#include "core/messages/convert.h"
#include "core/messages/envelope.h"
#include "core/messages/sender_check.h"

namespace evermap::messages {

// The message time guard. Time inside algorithms is message time (STYLE.md): one message
// stamped 2^62 adopted as "now" froze the mapper's tracking for the rest of a run. A message
// whose utime is more than `window_s` from the stream's recent clock (the utime of the last
// message passed on, any channel of the Inbox) is held, not passed on. Held messages that agree
// with each other (within the window) are a candidate clock; it is adopted when the streams
// have really moved (a new session, a log replayed again) and the old ones stopped:
//  - `confirm_count` of them have distinct stamps (copies of one message confirm nothing);
//  - they span `confirm_span_s` of their own message time, or fill half of `max_held`;
//  - fewer messages were passed on at the current clock since the first of them arrived than
//    they are: a jump the other streams (or the same stream) contradict by going on at the
//    clock is not adopted (a second robot, a log replayed beside the live one, forged stamps).
// Then the clock jumps to them, they are passed on in arrival order, nothing lost, and one line
// says so (clockJumps() counts them). A held message that no others confirm within
// `expire_count` messages passed on is refused and counted. Before the first confirmation the
// clock is not set: the first messages of a process are held until `confirm_count` of them
// agree (nothing contradicts them, so neither span nor count is asked of them).
struct TimeGuardOptions {
  // 0 turns the guard off.
  double window_s = 120.0;
  // Messages with distinct stamps agreeing on a new clock needed to adopt it (>= 1; 1 = adopt
  // at once).
  int confirm_count = 3;
  // Message time the agreeing messages must span before a jump of the clock is adopted,
  // seconds. 0.1 s is one frame or more of every evermap stream (VO 10-20 Hz, wheels 10-50 Hz,
  // ATTITUDE 50 Hz, IMU 200-1000 Hz) and the messages it holds stay within max_held (at 1 kHz
  // the half of max_held adopts first); a stream that really moved covers it within its first
  // frames, while stamps forged or corrupted together (2^62, 2^62 + 1 µs, ...) do not. 0: no
  // span asked.
  double confirm_span_s = 0.1;
  // A held message not confirmed after this many messages passed on is refused.
  int expire_count = 200;
  // Most messages held at once (the oldest is refused beyond it).
  int max_held = 64;

  Status validate() const;
};

struct ChannelCounts {
  int64_t received = 0;         // delivered by LCM to the Inbox
  int64_t malformed = 0;        // did not decode (wire layout, type hash, decoder)
  int64_t time_refused = 0;     // refused by the time guard
  int64_t refused = 0;          // the handler returned an Error
  int64_t failed = 0;           // the handler threw
  int64_t unauthenticated = 0;  // with a key: no valid MAC (sender_check.h)
  int64_t replayed = 0;         // with a key: a counter seen before, or outside the window
  int64_t other_sender = 0;     // from a sender other than the one the channel is locked onto
  int64_t dropped() const {
    return malformed + time_refused + refused + failed + unauthenticated + replayed + other_sender;
  }
};

class Inbox {
 public:
  // What a handler made of a message (internal; public for the templates below).
  struct Verdict {
    enum Kind { kOk, kMalformed, kRefused } kind = kOk;
    std::string message;
  };

  struct Options {
    std::string process = "evermap";  // the prefix of every line logged
    // Messages LCM may queue per subscription before it drops the oldest. LCM 1.3.1 drops
    // them without telling; docs/lcm.md.
    int queue_capacity = 30;
    TimeGuardOptions time;
    // Lines logged per channel and kind of drop, then one in every 1000.
    int64_t log_lines = 20;
    // This process as a sender (INPUT_STATS is published with it) and its key, if any: with
    // one, what is not authenticated with it is refused. A default Signer: no key, anonymous.
    Signer signer;
    SenderCheckOptions senders;

    Status validate() const;
  };

  // `lcm` must outlive the Inbox.
  Inbox(lcm::LCM& lcm, Options options);
  Inbox(const Inbox&) = delete;
  Inbox& operator=(const Inbox&) = delete;
  ~Inbox();

  // Handler: Status(const Msg&) or void(const Msg&). `queue_capacity` < 0: the Options' one;
  // 0 = unbounded, only where the consumer provably keeps up.
  template <typename Msg, typename Handler>
  void subscribe(const std::string& channel, Handler handler, int queue_capacity = -1) {
    add(channel, queue_capacity, wire::Layout<Msg>::kType, Msg::getHash(),
        [handler = std::move(handler), channel](const void* data, int64_t size) -> Verdict {
          auto msg = decodeLcm<Msg>(data, size, channel);
          if (!msg) return {Verdict::kMalformed, msg.error().message};
          if constexpr (std::is_same_v<std::invoke_result_t<Handler&, const Msg&>, void>) {
            handler(*msg);
            return {};
          } else {
            Status s = handler(*msg);
            if (!s) return {Verdict::kRefused, channel + ": " + s.error().message};
            return {};
          }
        });
  }

  // For a consumer that decodes later (vo-proc queues bytes for its worker): the bytes are
  // checked along Msg's layout and guarded as above, then passed on as they came.
  template <typename Msg>
  void subscribeBytes(const std::string& channel,
                      std::function<Status(const void* data, int64_t size)> handler,
                      int queue_capacity = -1) {
    add(channel, queue_capacity, wire::Layout<Msg>::kType, Msg::getHash(),
        [handler = std::move(handler), channel](const void* data, int64_t size) -> Verdict {
          Status s = handler(data, size);
          if (!s) return {Verdict::kRefused, channel + ": " + s.error().message};
          return {};
        });
  }

  // A channel on which many senders are expected (INPUT_STATS, the deputy's): not locked onto
  // one (sender_check.h).
  void shareChannel(const std::string& channel) { senders_.shareChannel(channel); }
  // The sender `channel` is locked onto ("anonymous" for messages without an envelope; empty
  // before any message).
  std::string senderOf(const std::string& channel) const;

  // A drop found after the handler (e.g. the consumer's own queue overflowed): counted as
  // refused on `channel`, logged as the others.
  void countRefused(const std::string& channel, const std::string& why);

  const std::map<std::string, ChannelCounts>& counts() const { return counts_; }
  ChannelCounts total() const;
  int64_t held() const { return static_cast<int64_t>(held_.size()); }
  // Jumps of the message clock adopted (a new session, a log replayed again) and candidate
  // jumps the streams going on at the clock contradicted (checks refused, not messages).
  int64_t clockJumps() const { return clock_jumps_; }
  int64_t jumpsContradicted() const { return jumps_contradicted_; }
  // "IMU 1000 received, 2 malformed, 0 time-refused, 0 refused, 0 failed; ATTITUDE ..."
  std::string summary() const;
  // Channel INPUT_STATS.
  evermap::input_stats_t statsMessage(int64_t utime) const;
  // Publishes statsMessage() on INPUT_STATS when `period_s` of wall time has passed since the
  // last one (for main loops; what is counted does not depend on it).
  void publishStatsEvery(double period_s);

 private:
  using Handler = std::function<Verdict(const void*, int64_t)>;
  struct Entry {
    Inbox* inbox;
    std::string channel;
    int type;
    int64_t hash;
    Handler handler;
    lcm::Subscription* subscription = nullptr;
  };
  struct Held {
    Entry* entry;
    int64_t utime;
    int64_t passed_at;  // passed_ when it was held
    std::vector<uint8_t> bytes;
  };

  void add(const std::string& channel, int queue_capacity, int type, int64_t hash, Handler handler);
  static void onMessage(const lcm::ReceiveBuffer* rbuf, const std::string& channel, Entry* entry);
  void receive(Entry& entry, const void* data, int64_t size);
  // The envelope's check; false when the message is dropped (counted), else `*size` is the
  // message's without the envelope.
  bool admit(Entry& entry, const void* data, int64_t* size);
  void deliver(Entry& entry, const void* data, int64_t size, int64_t utime);
  void guard(Entry& entry, const void* data, int64_t size, int64_t utime);
  // The held messages that agree with `utime` (indices into held_, in order) and whether they
  // move the clock (TimeGuardOptions).
  std::vector<size_t> agreeing(int64_t utime, int64_t window_us) const;
  bool confirmsJump(const std::vector<size_t>& agree);
  // The clock moves to `utime`; the agreeing messages are passed on.
  void jump(const std::vector<size_t>& agree, int64_t utime);
  void expireHeld();
  // Refuses the oldest held message (counted, one line ending in `why`).
  void refuseOldestHeld(const std::string& why);
  void log(const std::string& channel, int64_t count, const std::string& line);

  lcm::LCM& lcm_;
  Options o_;
  std::list<Entry> entries_;  // stable addresses: LCM holds pointers to them
  std::map<std::string, ChannelCounts> counts_;
  SenderCheck senders_;
  bool have_clock_ = false;
  int64_t clock_utime_ = 0;
  int64_t passed_ = 0;  // messages passed on the guard
  int64_t clock_jumps_ = 0;
  int64_t jumps_contradicted_ = 0;
  std::deque<Held> held_;
  std::chrono::steady_clock::time_point last_stats_{};
};

}  // namespace evermap::messages
