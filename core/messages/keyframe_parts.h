#pragma once
// A keyframe in parts (KEYFRAME_PART, keyframe_part_t; docs/deployment.md, "A lossy link"):
// a KEYFRAME is tens of IP packets and LCM has no retransmission, so a keyframe published
// again is cut into parts of one packet each, and the receiver asks for the parts it lacks.
//  - splitKeyframe: the parts of a keyframe's encoding (vo-proc);
//  - KeyframeAssembler: joins the parts received into keyframe_t (loopclose-proc), bounded,
//    and says which parts are missing.
// Threading: KeyframeAssembler is not thread-safe.

#include <cstdint>
#include <map>
#include <optional>
#include <vector>

#include <evermap/keyframe_part_t.hpp>
#include <evermap/keyframe_t.hpp>

#include "core/common/expected.h"

namespace evermap::messages {

// Bytes of a keyframe's encoding per part: one IP packet at an MTU of 1500 with the part's
// fields (32 bytes), LCM's header (22) and the largest envelope (envelope.h) around it.
inline constexpr int kKeyframePartBytes = 1200;
// Largest encoding a part may claim (a keyframe_t of kMaxKeyframeFeatures is 5.7 MB).
inline constexpr int32_t kMaxKeyframeBytes = 8 << 20;

// How many parts splitKeyframe makes of `keyframe`, from its encoded size alone (nothing is
// encoded): 0 when it cannot be split.
int keyframePartCount(const evermap::keyframe_t& keyframe, int part_bytes = kKeyframePartBytes);
// The parts of `keyframe`'s encoding, `part_bytes` each (the last one shorter), in index order.
// Empty when it cannot be encoded or would need more than 32767 parts.
std::vector<evermap::keyframe_part_t> splitKeyframe(const evermap::keyframe_t& keyframe,
                                                    int part_bytes = kKeyframePartBytes);

class KeyframeAssembler {
 public:
  // At most `max_bytes` of parts are held at once, over all keyframes.
  explicit KeyframeAssembler(int64_t max_bytes = 64 << 20) : max_bytes_(max_bytes) {}

  // A part received: the keyframe when this part completes it, nothing while parts are
  // missing, an Error naming the keyframe when the part is malformed, does not fit the parts
  // held (those are dropped), would exceed max_bytes, or completes parts that do not decode to
  // a keyframe_t of that utime. A part with another layout (total_bytes, count) than the
  // parts held starts the keyframe again; a part held already changes nothing.
  Expected<std::optional<evermap::keyframe_t>> add(const evermap::keyframe_part_t& part);
  // The indices of the parts of `keyframe_utime` not held; empty when none is held (all are
  // missing, or the layout is not known yet).
  std::vector<int16_t> missing(int64_t keyframe_utime) const;
  // Whether any part of `keyframe_utime` is held.
  bool holds(int64_t keyframe_utime) const { return open_.count(keyframe_utime) > 0; }
  // Drops the parts of `keyframe_utime` (it came whole, or it is no longer wanted).
  void erase(int64_t keyframe_utime);
  int64_t bytesHeld() const { return bytes_held_; }

 private:
  struct Open {
    int32_t total_bytes = 0;
    int16_t count = 0;
    std::map<int16_t, evermap::keyframe_part_t> parts;  // by index
  };
  Expected<evermap::keyframe_t> join(int64_t keyframe_utime, const Open& open) const;

  int64_t max_bytes_;
  int64_t bytes_held_ = 0;
  std::map<int64_t, Open> open_;  // by keyframe utime
};

}  // namespace evermap::messages
