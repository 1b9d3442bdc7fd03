#pragma once
// The mapper, the measurement-level simulator and the registration oracle in one process
// (DESIGN.md section 1: the offline runner used by tests, benchmarks and evaluation). The
// simulator's messages reach the mapper in time order, exactly the bytes a log would hold;
// each REGISTER_REQUEST is answered by the oracle as soon as the oracle knows the query
// keyframe (its KEYFRAME message follows the VO_DELTA that made it), each NODE_ADDED is told
// to the oracle likewise. Deterministic: same options, same result.

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "core/common/expected.h"
#include "core/sim/sim_options.h"
#include "mapper-proc/mapper.h"

namespace evermap::mapper {

struct OfflineRunSummary {
  MapperStats stats;
  int64_t nodes = 0;
  std::vector<int64_t> nodes_by_session;
  int64_t factors = 0;         // pair factors in the solver
  int64_t constraints = 0;     // every constraint kept
  int64_t messages = 0;        // simulator messages delivered
  int64_t decode_errors = 0;
  int64_t false_matches = 0;   // oracle answers that were false matches
  int64_t step_poses = 0;
  double ate_rmse_m = 0.0;     // step poses with the final node estimates, SE(3)-aligned
  double ate_median_m = 0.0;
  double duration_s = 0.0;     // simulated time
  double distance_m = 0.0;
  double update_median_ms = 0.0;
  double update_p99_ms = 0.0;
  int64_t store_transactions = 0;  // with a map store: one per update that changed the graph
  double store_s = 0.0;            // wall time spent writing them
  std::string text() const;
};

// Simulates `sim` and maps it; with a non-empty `store_file`, the map store is written after
// every update that changed the graph. Errors: invalid options, the store, or too few step
// poses for an ATE.
Expected<OfflineRunSummary> runOffline(const sim::SimOptions& sim, MapperOptions mapper,
                                       const std::filesystem::path& store_file = {});

}  // namespace evermap::mapper
