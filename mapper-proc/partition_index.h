#pragma once
// The place partition of Algorithm 1 (paper section IV-B, eq. 8): every node filed under the
// (floor, x, y, heading) cell its estimate falls in. A step asks it for the node of the place
// the robot is in: the newest node of its cell, else the nearest node whose view overlaps the
// place across a cell edge (MapperOptions::overlap_radius_cells and overlap_heading_sectors).
// No node there: a new place, and the step adds a node.
//
// The index follows the estimate lazily. New nodes are filed when the solver first estimates
// them; after a synchronous batch step every node is re-filed at once (rebuild), after a
// background batch step a few nodes per step (startRefresh, refresh): cells are 1 m, and
// between batch steps few old nodes cross a cell edge, while a rebuild costs O(nodes).

#include <cstddef>
#include <cstdint>
#include <functional>
#include <limits>
#include <optional>
#include <unordered_map>
#include <vector>

#include "core/geometry/se2.h"
#include "core/geometry/se3.h"
#include "core/solver/incremental_solver.h"
#include "mapper-proc/map_node.h"

namespace evermap::mapper {

class PartitionIndex {
 public:
  struct Options {
    double cell_size_m = 1.0;
    int heading_bins = 8;
    double overlap_radius_cells = 1.0;     // the overlap's radius, in cells
    double overlap_heading_sectors = 1.0;  // ... and its heading tolerance, in sectors
    int refresh_per_step = 200;            // nodes re-filed per step after a background batch
  };
  explicit PartitionIndex(const Options& options);
  // A node's pose in the world by id: the solver's estimate (the mapper), or a stored map's
  // fixed poses (the localizer, localizer.h).
  using NodePoses = std::function<core::SE3d(int64_t)>;

  core::PlanarCell cellOf(const core::SE3d& world_T_body, int floor) const;
  // The most recently added node of the cell (paper section IV-B) made no later than
  // newest_allowed.
  std::optional<int64_t> nodeInCell(const core::PlanarCell& cell, int64_t newest_allowed,
                                    const std::vector<MapperNode>& nodes) const;
  // The node closest to world_T_body within the overlap, searched in the neighbouring cells
  // and sectors, on the floor.
  std::optional<int64_t> overlappingNode(const core::SE3d& world_T_body, int floor,
                                         int64_t newest_allowed,
                                         const std::vector<MapperNode>& nodes,
                                         const solver::IncrementalSolver& solver) const;
  // The node of the place world_T_body is in: its cell's, else the one overlapping it.
  std::optional<int64_t> nodeAt(const core::SE3d& world_T_body, int floor, int64_t newest_allowed,
                                const std::vector<MapperNode>& nodes,
                                const solver::IncrementalSolver& solver) const;
  std::optional<int64_t> nodeAt(const core::SE3d& world_T_body, int floor, int64_t newest_allowed,
                                const std::vector<MapperNode>& nodes, const NodePoses& poses) const;

  // The overlap's heading tolerance (overlap_heading_sectors of a sector), and how far apart
  // two headings are (radians, in [0, π]).
  double overlapHeadingRad() const;
  static double headingApartRad(const core::SE2d& a, const core::SE2d& b);

  // Files node `id` in `cell` (moving it from its old one). Nodes are filed first in id order.
  void file(int64_t id, const core::PlanarCell& cell);
  // Node `id` is no place of the map any more (a quarantined session's, mapper.h): it leaves its
  // cell, and filing it again keeps it out.
  void quarantine(int64_t id);
  // Every node re-filed at the estimate.
  void rebuild(const std::vector<MapperNode>& nodes, const solver::Values& estimate);
  // After a background batch step: re-file refresh_per_step nodes at each refresh() from now.
  void startRefresh() { refresh_next_ = 0; }
  // Re-files the next refresh_per_step nodes whose cell moved with the estimate; false when
  // no refresh is under way.
  bool refresh(const std::vector<MapperNode>& nodes, const solver::IncrementalSolver& solver);

 private:
  // overlappingNode's search within radius_m and heading_rad, at most the overlap's.
  std::optional<int64_t> closestNode(const core::SE3d& world_T_body, int floor,
                                     int64_t newest_allowed, const std::vector<MapperNode>& nodes,
                                     const NodePoses& poses, double radius_m,
                                     double heading_rad) const;
  Options o_;
  core::PlanarGrid grid_;
  // Nodes of each cell, ascending ids; node_cell_[id] is the cell node id is filed under.
  std::unordered_map<core::PlanarCell, std::vector<int64_t>, core::PlanarCellHash> cells_;
  std::vector<core::PlanarCell> node_cell_;
  std::vector<bool> quarantined_;   // by id
  size_t refresh_next_ = SIZE_MAX;  // next node to re-file after a swap; SIZE_MAX: none
};

}  // namespace evermap::mapper
