#pragma once
// vo-proc's side of keyframe recovery (docs/deployment.md, "A lossy link"): a KEYFRAME is
// tens of UDP fragments, and LCM has no retransmission, so on a lossy link a receiver that
// missed one asks for it again on KEYFRAME_REQUEST (keyframe_request_t) and vo-proc publishes
// it again from the recent keyframes it keeps, in parts of one IP packet each
// (KEYFRAME_PART, core/messages/keyframe_parts.h): the parts the receiver says it lacks.
//  - KeyframeBuffer: the recent published keyframes, bounded by count and by seconds of their
//    own (message) time;
//  - KeyframeResender: answers a request from the buffer, at a bounded rate: a keyframe once
//    per `min_interval_s` at most, `max_rate_hz` keyframes' worth of parts a second at most
//    (a burst of one second's worth), so no request, hostile or repeated, makes vo-proc flood
//    the link.
// The resender's clock is the caller's (wall seconds in vo-proc: the rate bounds link
// bandwidth, not data), so tests give it their own. Threading: neither class is thread-safe;
// vo-proc serialises keep() and answer() with its KEYFRAME publishing.

#include <cstdint>
#include <deque>
#include <optional>
#include <string>

#include <vector>

#include <evermap/keyframe_part_t.hpp>
#include <evermap/keyframe_request_t.hpp>
#include <evermap/keyframe_t.hpp>

#include "core/common/expected.h"
#include "core/common/option_fields.h"

namespace evermap::vo {

struct KeyframeResendOptions {
  // Keyframes kept at most (about 37 KB each). 0 keeps none: requests are not answered.
  int keyframes = 120;
  // Keyframes older than this behind the newest one are dropped, seconds of message time. A
  // receiver asks for a keyframe over about 20 s (loopclose-proc's recovery options).
  double seconds = 60.0;
  // One keyframe is published again at most once per this, seconds.
  double min_interval_s = 0.1;
  // Keyframes' worth of parts published again per second at most, all together (10: 0.37
  // MB/s at most).
  double max_rate_hz = 10.0;

  Status validate() const;
  void declareOptions(OptionList& o) {
    o.add("keyframes", &keyframes, "", "recent keyframes kept to publish again (0: none)")
        .in(0, 10000);
    o.add("seconds", &seconds, "s", "keyframes older than this behind the newest are dropped")
        .positive();
    o.add("min_interval_s", &min_interval_s, "s", "one keyframe published again once per this")
        .nonNegative();
    o.add("max_rate_hz", &max_rate_hz, "Hz",
          "keyframes' worth of parts published again per second at most")
        .positive();
  }
};

class KeyframeBuffer {
 public:
  KeyframeBuffer(int max_keyframes, double max_age_s)
      : max_keyframes_(max_keyframes), max_age_us_(static_cast<int64_t>(max_age_s * 1e6)) {}

  // Keeps `keyframe`, then drops the oldest beyond the bounds. A keyframe not after the
  // newest one starts the buffer again (a new stream: a log replayed again, a restart).
  void keep(const evermap::keyframe_t& keyframe);
  // The kept keyframe of that utime, or null.
  const evermap::keyframe_t* find(int64_t utime) const;
  size_t size() const { return keyframes_.size(); }

 private:
  int max_keyframes_;
  int64_t max_age_us_;
  std::deque<evermap::keyframe_t> keyframes_;  // oldest first, utimes increasing
};

struct ResendStats {
  int64_t requests = 0;
  int64_t resent = 0;        // requests answered
  int64_t parts = 0;         // KEYFRAME_PARTs published
  int64_t unknown = 0;       // not (or no longer) kept
  int64_t too_soon = 0;      // the same keyframe within min_interval_s
  int64_t over_rate = 0;     // beyond max_rate_hz
  std::string text() const;  // one line
};

class KeyframeResender {
 public:
  // Precondition: options.validate().
  explicit KeyframeResender(const KeyframeResendOptions& options);

  // A keyframe just published.
  void keep(const evermap::keyframe_t& keyframe) { buffer_.keep(keyframe); }
  // A request received at `now_s` (the caller's clock, seconds): the parts to publish, those
  // the request lists as missing (all when it lists none), or nothing (counted: unknown, also
  // when it lists no part of the keyframe; too soon; over the rate).
  std::vector<evermap::keyframe_part_t> answer(const evermap::keyframe_request_t& request,
                                               double now_s);
  const ResendStats& stats() const { return stats_; }
  const KeyframeBuffer& buffer() const { return buffer_; }

 private:
  // Which of a keyframe's `count` parts a request wants: those `missing` names (indices out
  // of range are ignored), all when it names none.
  static std::vector<bool> wanted(int count, const std::vector<int16_t>& missing);

  KeyframeResendOptions options_;
  KeyframeBuffer buffer_;
  double tokens_;                 // resends allowed now (a token bucket)
  std::optional<double> last_s_;  // when tokens_ was last filled
  struct Sent {
    int64_t utime;
    double at_s;
  };
  std::deque<Sent> sent_;  // recent resends, for min_interval_s
  ResendStats stats_;
};

}  // namespace evermap::vo
