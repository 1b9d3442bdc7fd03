#include "mapper-proc/tracker_counts.h"

namespace evermap::mapper {

// Every field is a count of the list: one added there and not here fails to compile.
static_assert(sizeof(TrackerCounts) == 20 * sizeof(int64_t));

const std::array<TrackerCounts::Counter, 20>& TrackerCounts::counters() {
  using T = TrackerCounts;
  static const std::array<Counter, 20> list{{
      {"vo_applied", &T::vo_applied},
      {"vo_failed", &T::vo_failed},
      {"wheel_applied", &T::wheel_applied},
      {"vo_restarts", &T::restarts},
      {"relinked", &T::relinked},
      {"relinks_refused", &T::relinks_refused},
      {"relinks_weaker", &T::relinks_weaker},
      {"reanchored", &T::reanchored},
      {"odometry_bridged", &T::odometry_bridged},
      {"vo_timeouts", &T::vo_timeouts},
      {"gyro_turns", &T::gyro_turns},
      {"vo_contradicted", &T::vo_contradicted},
      {"wheel_fused", &T::wheel_fused},
      {"wheel_disagreed", &T::wheel_disagreed},
      {"heading_waits", &T::heading_waits},
      {"heading_waits_expired", &T::heading_waits_expired},
      {"wheels_taken_back", &T::wheels_taken_back},
      {"implausible_motion", &T::implausible},
      {"odometry_refused", &T::odometry_refused},
      {"odometry_dropped", &T::dropped},
  }};
  return list;
}

}  // namespace evermap::mapper
