#pragma once
// Synthetic false loop closures for robustness tests (as in Sünderhauf & Protzel 2012 and
// Agarwal et al. 2013): random pairs of poses joined by random relative poses, with the
// information matrix of a randomly chosen real loop closure, inserted into the edge stream
// right after both poses exist (so an incremental run sees them online).

#include <cstdint>

#include "core/solver/graph_io.h"

namespace evermap::solver {

struct OutlierOptions {
  int count = 0;
  uint32_t seed = 1;
  // Translations uniform in [−range, range] per axis (metres); rotations uniform.
  double translation_range_m = 10.0;
};

// A copy of `graph` with `count` false loop closures inserted; their `line` is 0.
GraphFile addFalseLoopClosures(const GraphFile& graph, const OutlierOptions& options);
bool isSyntheticOutlier(const GraphEdge& edge);

}  // namespace evermap::solver
