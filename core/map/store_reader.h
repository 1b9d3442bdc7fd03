#pragma once
// Reading a map store (core/map/store_file.h) into a MapSnapshot: what the viewer shows, the
// tools evaluate and a restarted mapper restores (Mapper::restore). The one reader of the
// schema.

#include "core/common/expected.h"
#include "core/map/map_snapshot.h"
#include "core/map/store_file.h"

namespace evermap::map {

// Every row of the map's tables, nodes and edges by id. A row that is not what the schema
// says (a blob of the wrong size, a quaternion that is not unit, a covariance that is not
// finite, an attitude of no node) is an error naming the file and the row.
Expected<MapSnapshot> readMap(const StoreFile& file);

}  // namespace evermap::map
