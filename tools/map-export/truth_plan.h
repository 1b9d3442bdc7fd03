#pragma once
// Floor plans against the image-level simulator's building (evermap-map-export --truth): the
// simulator knows every wall (tools/sim/render_world.h: a floor's regions rasterised, a wall at
// every grid edge between different regions outside the doors). The map is put in the
// building's frame by the 2-D rigid fit (yaw and translation; the map is gravity-aligned) of
// its nodes to their true positions (evermap-slam-run's nodes.csv), and each map floor is
// compared with the true floor most of its nodes are on:
//   precision  occupied cells whose centre is within tolerance_m of a true wall
//   recall     true wall samples (every 5 cm) in the mapped area with an occupied cell
//              centre within tolerance_m; the mapped area is what the plan saw free within
//              0.5 m of the wall
//   free IoU   over the cells the plan saw (free or occupied): plan free against truly inside
//              a room, corridor or cab

#include <filesystem>
#include <string>
#include <vector>

#include "core/common/expected.h"
#include "core/geometry/se3.h"
#include "tools/map-export/floor_plans.h"
#include "tools/sim/image_sim_options.h"

namespace evermap::map_export {

struct FloorScore {
  int floor = 0;       // map floor
  int true_floor = 0;  // building floor
  int64_t occupied = 0, occupied_near_wall = 0;
  int64_t wall_samples = 0, wall_samples_found = 0;  // in the mapped area
  int64_t free_intersection = 0, free_union = 0;
  double precision() const { return occupied ? double(occupied_near_wall) / occupied : 0.0; }
  double recall() const { return wall_samples ? double(wall_samples_found) / wall_samples : 0.0; }
  double freeIou() const { return free_union ? double(free_intersection) / free_union : 0.0; }
};

struct TruthComparison {
  core::SE3d truth_T_map;  // the fit (yaw and x, y)
  double fit_rmse_m = 0.0;
  std::vector<FloorScore> floors;
  std::string text() const;
};

class BuildingTruth {
 public:
  // The building of a simulator config (config/sim-image-*.conf) and the true node positions
  // of slam-run's nodes.csv (node, true_floor, x, y, true_x, true_y columns).
  static Expected<BuildingTruth> load(const sim::ImageSimOptions& options,
                                      const std::filesystem::path& nodes_csv);
  Expected<TruthComparison> compare(const std::vector<FloorPlan>& plans, const ScanSet& scans,
                                    double tolerance_m) const;
  // The plan with the true walls drawn over it (map frame), PNG or SVG by the extension.
  Status drawFloor(const FloorPlan& plan, const TruthComparison& c,
                   const std::filesystem::path& file) const;

  struct Wall {
    core::Vec2 a, b;  // building frame
  };
  struct TrueFloor {
    std::vector<Wall> walls;
    std::vector<core::Vec2> samples;  // every ~5 cm along the walls
    double x0 = 0, y0 = 0, cell = 0.05;
    int w = 0, h = 0;
    std::vector<uint8_t> inside;  // 1: a region's cell
    bool isInside(const core::Vec2& p) const;
  };

 private:
  std::vector<TrueFloor> floors_;
  struct NodeTruth {
    int64_t node = 0;
    int true_floor = 0;
    core::Vec2 est, truth;
  };
  std::vector<NodeTruth> nodes_;
};

}  // namespace evermap::map_export
