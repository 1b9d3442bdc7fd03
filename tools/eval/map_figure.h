#pragma once
// The map with its floors stacked, like the paper's Fig. 1: every floor's nodes and edges drawn
// on a plate at the floor's height, in an oblique view (the horizontal plane turned by an
// azimuth and flattened, height exaggerated so that floors separate), nodes coloured by the
// session that created them, loop closures in red. PNG or SVG by the file's extension.

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "core/common/expected.h"
#include "core/geometry/so3.h"
#include "tools/eval/canvas.h"

namespace evermap::eval {

struct MapFigureNode {
  core::Vec3 p_world = core::Vec3::Zero();  // metres
  int floor = 0;
  int session = 0;
};

struct MapFigureEdge {
  size_t a = 0;  // indices into the node list
  size_t b = 0;
  bool loop_closure = false;
};

struct MapFigure {
  std::vector<MapFigureNode> nodes;
  std::vector<MapFigureEdge> edges;
  // Optional: a reference trajectory (e.g. ground truth) drawn thin and grey under the map.
  std::vector<core::Vec3> reference;
};

struct MapFigureOptions {
  std::string title;
  std::string subtitle;
  double azimuth_deg = -30.0;  // turn of the horizontal plane before projecting
  double flatten = 0.45;       // factor on the depth axis of the horizontal plane (0, 1]
  // Vertical distance drawn between consecutive floors, as a fraction of the horizontal
  // extent: floors 3 m apart would otherwise overlap in a 100 m wide building.
  double floor_spacing = 0.35;
  int width_px = 1200;
  int height_px = 1000;

  Status validate() const;
};

struct MapFigureSummary {
  size_t floors = 0;
  size_t sessions = 0;
  size_t loop_closures = 0;
};

// Errors: no nodes, a non-finite position, an edge index out of range, bad options.
Expected<Canvas> drawMapFigure(const MapFigure& figure, const MapFigureOptions& options,
                               MapFigureSummary* summary = nullptr);

}  // namespace evermap::eval
