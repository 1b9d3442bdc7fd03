#include "mapper-proc/mapper_stats.h"

#include <cstddef>
#include <sstream>

namespace evermap::mapper {

// Every field before timing is a counter of the list: a counter added there and not here
// fails to compile.
static_assert(offsetof(MapperStats, timing) == 39 * sizeof(int64_t));

const std::array<MapperStats::Counter, 39>& MapperStats::counters() {
  using S = MapperStats;
  static const std::array<Counter, 39> list{{
      {"steps", &S::steps},
      {"nodes", &S::nodes},
      {"constraints", &S::constraints},
      {"factors", &S::factors},
      {"merged", &S::merged},
      {"rejected_inconsistent", &S::rejected_inconsistent},
      {"requests_node", &S::requests_node},
      {"requests_global", &S::requests_global},
      {"registrations_ok", &S::registrations_ok},
      {"loop_closures", &S::loop_closures},
      {"delta_replaced", &S::delta_replaced},
      {"delta_kept", &S::delta_kept},
      {"delta_fused", &S::delta_fused},
      {"rejected_map_gate", &S::rejected_map_gate},
      {"rejected_floor", &S::rejected_floor},
      {"closures_saturated", &S::closures_saturated},
      {"footprints", &S::footprints},
      {"gate_recoveries", &S::gate_recoveries},
      {"recoveries_too_far", &S::recoveries_too_far},
      {"relocalizations", &S::relocalizations},
      {"timeouts", &S::timeouts},
      {"dropped", &S::dropped},
      {"relocalization_disagreements", &S::relocalization_disagreements},
      {"relocalization_same_frame_checks", &S::relocalization_same_frame_checks},
      {"restored_nodes", &S::restored_nodes},
      {"implausible_floors", &S::implausible_floors},
      {"restored_constraints", &S::restored_constraints},
      {"warm_restarts", &S::warm_restarts},
      {"lost_restarts", &S::lost_restarts},
      {"warm_confirmations", &S::warm_confirmations},
      {"warm_rejections", &S::warm_rejections},
      {"warm_bridged", &S::warm_bridged},
      {"warm_bridged_by_wheels", &S::warm_bridged_by_wheels},
      {"warm_wheel_waits", &S::warm_wheel_waits},
      {"warm_elevator_refusals", &S::warm_elevator_refusals},
      {"sessions_quarantined", &S::sessions_quarantined},
      {"nodes_quarantined", &S::nodes_quarantined},
      {"registrations_quarantined", &S::registrations_quarantined},
      {"floor_heights_replaced", &S::floor_heights_replaced},
  }};
  return list;
}

std::string MapperStats::text() const {
  std::ostringstream s;
  for (const Counter& c : counters()) s << c.name << " " << this->*c.field << "\n";
  return s.str();
}

void MapperStats::addCounters(const MapperStats& o) {
  for (const Counter& c : counters()) this->*c.field += o.*c.field;
}

}  // namespace evermap::mapper
