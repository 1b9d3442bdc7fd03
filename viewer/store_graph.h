#pragma once
// A stored map (core/map/store_file.h) as the MAP_GRAPH the mapper would publish for it, so
// `evermap-viewer --store map.db` shows it through the same path as a live map.

#include <cstdint>
#include <filesystem>

#include <evermap/map_graph_t.hpp>

#include "core/common/expected.h"
#include "core/map/map_snapshot.h"

namespace evermap::viewer {

struct StoredGraph {
  map_graph_t graph;
  int64_t rejected = 0;  // constraints the store holds as rejected (rows and folds)
};

// One edge per node pair: TYPE_LOOP when an accepted constraint of the pair is a loop closure,
// num_measurements = the pair's accepted constraints (a fold counts its members). Pairs with
// no accepted constraint are left out (they are not in the mapper's factor graph either).
StoredGraph graphFromSnapshot(const map::MapSnapshot& snapshot);

// Loads the store, opened read-only (a file that is missing or not a map store is an error
// naming it; nothing is written).
Expected<StoredGraph> loadStoredGraph(const std::filesystem::path& file);

}  // namespace evermap::viewer
