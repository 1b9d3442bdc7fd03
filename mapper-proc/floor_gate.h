#pragma once
// Plausibility of FLOOR content (issue 17, deliverable 3): a floor_t whose height no building
// has, or whose height changed since the previous FLOOR message of the session faster than
// any elevator moves, is refused before the mapper uses it (the caller counts it, as a
// malformed message, and leaves its estimate as it was). Physics bounds, not noise gates,
// above every data set here, as the tracker's odometry gates (tracker.h).
//
// Heights, not floor indices: elevator-proc numbers floors in the order it finds them
// (elevator-proc/floor_table.h), so a change of index says nothing of how far the cab went.
// A height change without a ride is bounded by the same speed, not by zero: a restarted
// elevator-proc measures heights from the floor it starts on, so its first ride's start may
// name another height than the last FLOOR message (seconds or more before it) without
// anything having moved.
//
// Threading: none; the mapper's thread.

#include <cstdint>
#include <optional>
#include <string>

#include <evermap/floor_t.hpp>

#include "core/common/expected.h"
#include "core/common/option_fields.h"

namespace evermap::mapper {

struct FloorGateOptions {
  // |height_m| at most, metres. Heights are relative to the floor the session started on;
  // the tallest building (Burj Khalifa) is 828 m high.
  double max_height_m = 1000.0;
  // |Δheight| / Δt between two FLOOR messages of a session at most (a ride's start and its
  // end, or the end and the next start), m/s; spans shorter than 1 ms count as 1 ms. The
  // fastest passenger elevators run at 21 m/s (Guangzhou CTF Finance Centre); our data: the
  // 74 m ride of elevator-android-skyscraper at ~4 m/s, the simulator's rides at 1-2 m/s.
  double max_vertical_speed_m_s = 25.0;

  void declareOptions(OptionList& o) {
    o.add("max_height_m", &max_height_m, "m", "a FLOOR height beyond ± this is refused").positive();
    o.add("max_vertical_speed_m_s", &max_vertical_speed_m_s, "m/s",
          "a FLOOR height changing faster than this is refused")
        .positive();
  }
  Status validate() const { return checkOptionRanges(*this, "floor_gate."); }
};

class FloorGate {
 public:
  explicit FloorGate(const FloorGateOptions& options = {}) : o_(options) {}

  // "" when `msg` is plausible after the messages accepted so far, else why not (one line
  // naming the bound). A session start (EVENT_NONE) is checked against max_height_m only:
  // the operator says where a session begins, wherever the last one ended.
  std::string check(const floor_t& msg) const;
  // The mapper used `msg`: the next message is checked against it.
  void accept(const floor_t& msg) { last_ = msg; }

  const FloorGateOptions& options() const { return o_; }

 private:
  FloorGateOptions o_;
  std::optional<floor_t> last_;  // the last FLOOR message accepted
};

}  // namespace evermap::mapper
