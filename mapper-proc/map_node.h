#pragma once
// A node of the map as the mapper keeps it besides its pose (which the solver holds), and what
// the map store saves and restores of the mapper (the snapshot): plain data of core/map, which
// the mapper's code names in its own namespace.

#include "core/map/map_snapshot.h"

namespace evermap::mapper {

using map::MapperNode;
using map::MapSnapshot;
using map::NodeAttitude;
using map::StoredEdge;
using map::StoredNode;
using map::TrackingState;

}  // namespace evermap::mapper
