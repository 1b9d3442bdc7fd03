#pragma once
// loopclose-proc's side of keyframe recovery (docs/deployment.md, "A lossy link"): the
// keyframes it needs (named by a NODE_ADDED or a REGISTER_REQUEST) and does not hold, asked of
// vo-proc again on KEYFRAME_REQUEST until they come or the attempts are spent. vo-proc answers
// in parts of one IP packet (KEYFRAME_PART): the parts received are joined here, and each ask
// after the first names the parts still missing, so a lost packet costs one part again, not
// the whole keyframe.
//
// A keyframe needed is first given `first_ask_after_us` to come on its own (vo-proc sends it
// right after the frame's VO_DELTA, and the mapper's NODE_ADDED or request on that VO_DELTA is
// one datagram against tens: it usually comes first); then it is asked for, and again after
// `retry_us`, growing by `backoff` up to `max_retry_us`, `max_attempts` times in all; then it
// is given up. Time is data time (the caller's clock): during a partition no data comes, so
// no attempt is spent on it. Counted: keyframes asked for, asks sent, recovered (came after an
// ask), given up. At most `max_open` keyframes are awaited at once; beyond, a need is refused
// (counted) and the caller does without.
// Threading: one thread (the LoopCloser's).

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <evermap/keyframe_part_t.hpp>
#include <evermap/keyframe_request_t.hpp>
#include <evermap/keyframe_t.hpp>

#include "core/common/expected.h"
#include "core/common/option_fields.h"
#include "core/messages/keyframe_parts.h"

namespace evermap::loopclose {

struct KeyframeRequestOptions {
  // Asks per keyframe at most; 0: never ask (a lost keyframe is lost for good). At 5 % packet
  // loss an ask or its answer's part is lost one time in ten: the 31 parts of a 37 KB keyframe
  // are all held after 3 or 4 asks; 16, over about 14 s of data time, cover a link that loses
  // half its packets.
  int max_attempts = 16;
  // Data time a needed keyframe is given to come on its own before the first ask, µs.
  int64_t first_ask_after_us = 150'000;
  // Data time between the first ask and the second, µs; each later wait is `backoff` times
  // the one before, up to max_retry_us. A request waits for its keyframe max_request_age_us
  // (2 s): the asks come close enough for 8 of them within 2 s.
  int64_t retry_us = 100'000;
  double backoff = 1.3;
  int64_t max_retry_us = 2'000'000;
  // Keyframes awaited at once at most.
  int max_open = 64;

  Status validate() const;
  void declareOptions(OptionList& o) {
    o.add("max_attempts", &max_attempts, "", "asks for a missed keyframe at most (0: never ask)")
        .in(0, 1000);
    o.add("first_ask_after_us", &first_ask_after_us, "us",
          "a needed keyframe may come on its own this long before it is asked for")
        .nonNegative();
    o.add("retry_us", &retry_us, "us", "wait after the first ask before the second").positive();
    o.add("backoff", &backoff, "", "each wait between asks is this times the one before").min(1.0);
    o.add("max_retry_us", &max_retry_us, "us", "longest wait between two asks").positive();
    o.add("max_open", &max_open, "", "keyframes awaited at once at most").min(1);
  }
};

struct KeyframeRequestStats {
  int64_t asked = 0;          // keyframes asked for at least once
  int64_t asks = 0;           // KEYFRAME_REQUEST messages
  int64_t recovered = 0;      // asked for, then came
  int64_t given_up = 0;       // asked max_attempts times and never came
  int64_t refused = 0;        // needed while max_open were awaited
  int64_t parts = 0;          // KEYFRAME_PARTs of awaited keyframes received
  int64_t parts_unasked = 0;  // KEYFRAME_PARTs of keyframes not awaited (ignored)
  std::string text() const;   // one line
};

class KeyframeRequests {
 public:
  // Precondition: options.validate().
  explicit KeyframeRequests(const KeyframeRequestOptions& options) : options_(options) {}

  bool enabled() const { return options_.max_attempts > 0; }
  // A keyframe needed at data time `now` and not held: awaited (once; a second need of the
  // same keyframe changes nothing). False when it cannot be awaited (disabled, max_open).
  bool need(int64_t keyframe_utime, int64_t now);
  // Whether the keyframe is awaited.
  bool awaits(int64_t keyframe_utime) const { return open_.count(keyframe_utime) > 0; }
  // The keyframe came: no longer awaited (recovered when it had been asked for).
  void received(int64_t keyframe_utime);
  // A KEYFRAME_PART: the keyframe when it completes an awaited one (the caller takes it as a
  // KEYFRAME: received() follows), nothing while parts are missing or when the keyframe is
  // not awaited (counted), an Error naming it when the part is malformed
  // (messages::KeyframeAssembler).
  Expected<std::optional<evermap::keyframe_t>> addPart(const evermap::keyframe_part_t& part);
  // The asks due at data time `now`, each naming the parts still missing (none: all); keyframes
  // whose asks are spent are given up and their utimes appended to `given_up`.
  std::vector<evermap::keyframe_request_t> due(int64_t now, std::vector<int64_t>* given_up);
  size_t open() const { return open_.size(); }
  const KeyframeRequestStats& stats() const { return stats_; }

 private:
  struct Open {
    int attempts = 0;     // asks sent
    int64_t next_us = 0;  // data time of the next ask (or of giving up)
    int64_t wait_us = 0;  // the wait after the last ask
  };
  KeyframeRequestOptions options_;
  std::map<int64_t, Open> open_;       // by keyframe utime
  messages::KeyframeAssembler parts_;  // of the keyframes in open_
  KeyframeRequestStats stats_;
};

}  // namespace evermap::loopclose
