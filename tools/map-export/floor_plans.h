#pragma once
// The files evermap-map-export writes into its folder, each through a temporary name and a
// rename (core/common/atomic_write.h):
//   floor-N.pgm, floor-N.yaml  per map floor N: the occupancy grid (occupancy_grid.h)
//   nodes.csv                  node, session, floor, keyframe_utime, x y z qw qx qy qz
//                              (world_T_body, the map's current poses)
//   edges.csv                  edge, from, to, kind, accepted, the two nodes' floors and
//                              sessions, from_T_to (x y z qw qx qy qz)
//   points.ply                 every used keyframe point in the map frame (binary, float xyz)
// A floor's surface is the median height of its nodes' body origins (the body frame sits on
// the floor).

#include <cstdint>
#include <filesystem>
#include <map>
#include <vector>

#include "core/common/expected.h"
#include "core/map/map_snapshot.h"
#include "tools/map-export/map_scans.h"
#include "tools/map-export/occupancy_grid.h"

namespace evermap::map_export {

struct FloorPlan {
  int floor = 0;
  double floor_z = 0.0;  // map frame
  int64_t nodes = 0;
  OccupancyGrid grid{0, 0, 0, 0, 1.0};
};

// One grid per floor that has scans, floors ascending.
std::vector<FloorPlan> makeFloorPlans(const ScanSet& scans, const GridOptions& o);

struct ExportSummary {
  int64_t files = 0;
  int64_t bytes = 0;   // of every file written
  int64_t points = 0;  // in points.ply
};

Expected<ExportSummary> writeExport(const std::filesystem::path& dir, const map::MapSnapshot& map,
                                    const ScanSet& scans, const std::vector<FloorPlan>& plans,
                                    double max_range_m);

}  // namespace evermap::map_export
