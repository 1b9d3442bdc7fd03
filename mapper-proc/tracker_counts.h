#pragma once
// What the tracker (tracker.h) counts, listed once for the summaries and MAPPER_STATS.

#include <array>
#include <cstdint>
#include <string_view>

namespace evermap::mapper {

struct TrackerCounts {
  int64_t vo_applied = 0;
  int64_t vo_failed = 0;         // frames with a failure status
  int64_t wheel_applied = 0;     // increments compounded while VO was down
  int64_t dropped = 0;           // malformed, non-finite, out of order or implausible
  int64_t implausible = 0;       // ... of which motion beyond max_speed_m_s / max_turn_rad_s
  int64_t restarts = 0;          // VO restarted from a new reference (first frame, chain break)
  int64_t relinked = 0;          // VO back on its kept reference after failing: wheel undone
  int64_t relinks_refused = 0;   // ... (or bridged over a silence) whose motion contradicted
                                 // the wheels: reanchored instead
  int64_t relinks_weaker = 0;    // ... whose motion was less certain than the wheels' over the
                                 // gap (VO's motion prior bridging a break): reanchored instead
  int64_t reanchored = 0;        // VO on a reference the tracker did not know
  int64_t odometry_bridged = 0;  // ... placed by VO's odometry frame since the last frame taken
                                 // (a lost keyframe change, a silence the wheels carried), not
                                 // where the estimate was
  int64_t vo_timeouts = 0;       // VO silent for vo_timeout_s: wheel odometry took over
  int64_t gyro_turns = 0;        // wheel increments and VO keyframe steps whose yaw was fused
                                 // with the gyro's
  int64_t odometry_refused = 0;  // VO_DELTAs whose odometry pose (odom_*) was malformed: the
                                 // frame is used, its pose is not
  int64_t vo_contradicted = 0;   // keyframe steps, and VO's motions before a failure, whose yaw
                                 // the gyro contradicted (vo_gyro_gate)
  int64_t wheel_fused = 0;       // keyframe steps whose translation was fused with the wheels'
  int64_t wheel_disagreed = 0;   // ... where the two disagreed beyond χ²(2) 13.82 (99.9 %): a
                                 // fault one of the two covariances did not know
  int64_t heading_waits = 0;     // keyframe steps held for the heading that covers them
  int64_t heading_waits_expired = 0;  // ... taken before one came (heading_wait_s)
  int64_t wheels_taken_back = 0;      // wheel increments a late VO restart covers (vo-proc's hold)

  // Every count above, once: its name (the summaries', MAPPER_STATS') and its field.
  struct Counter {
    std::string_view name;
    int64_t TrackerCounts::*field;
  };
  static const std::array<Counter, 20>& counters();
  // Adds another tracker's counts (sessions tracked by successive trackers).
  void add(const TrackerCounts& o) {
    for (const Counter& c : counters()) this->*c.field += o.*c.field;
  }
};

}  // namespace evermap::mapper
