#pragma once
// A synthetic client of the registration oracle, to measure the oracle's cost and answer
// rates at the paper's scale without a mapper. It is NOT a mapper: it places nodes by ground
// truth. A node is added whenever a keyframe's true camera pose falls into an empty cell of a
// per-floor (x, y, heading) grid (the reduced pose graph's rule, paper section IV-B, applied
// to ground truth); at request_rate_hz of keyframe time it asks MODE_NODE against the node of
// the keyframe's cell (the "active node") and, when that fails, MODE_GLOBAL on the floor.

#include <cstdint>
#include <unordered_map>

#include "core/geometry/se2.h"
#include "tools/sim/registration_oracle.h"

namespace evermap::sim {

struct RequestLoadOptions {
  double request_rate_hz = 2.0;  // the paper's loop-closure rate
  double cell_size_m = 1.0;
  int heading_bins = 8;
};

struct RequestLoadSummary {
  int64_t nodes_added = 0;
  int64_t node_requests = 0;
  int64_t global_requests = 0;
};

class RequestLoad {
 public:
  RequestLoad(RegistrationOracle& oracle, const RequestLoadOptions& options);
  // Feeds the keyframe to the oracle, then adds a node or asks for registrations.
  void onKeyframe(const KeyframeTruth& keyframe);
  const RequestLoadSummary& summary() const { return summary_; }

 private:
  RegistrationOracle& oracle_;
  RequestLoadOptions o_;
  core::PlanarGrid grid_;
  std::unordered_map<core::PlanarCell, int64_t, core::PlanarCellHash> cells_;
  int64_t next_node_id_ = 0;
  int64_t next_request_id_ = 0;
  int64_t last_request_utime_ = INT64_MIN / 2;
  RequestLoadSummary summary_;
};

}  // namespace evermap::sim
