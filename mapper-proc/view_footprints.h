#pragma once
// The places a node has been seen from (MapperOptions::footprints). A registration to node n
// from a place where the partition has no node (no node in the step's cell, none overlapping
// it) shows that n serves that place: the robot's pose is filed as a footprint of n, kept
// relative to n, so it moves with n's estimate. In a later session Algorithm 1 treats the
// place as mapped: a step within half a cell and half a heading sector of a footprint asks
// its node (the node known to register from there; the active node may be far), and a failed
// registration there adds no node (the place is not new). Without
// footprints the first visits leave such places between nodes (a registration reaches 1-2 m,
// a node is made only where one fails), and later visits fill them one failed registration
// at a time for hundreds of hours: the map grew with the time the robot ran, not with the
// views it met (docs/results/mapper.md, "A year").
//
// Within the session that made them footprints do not count, so a first visit maps as
// Algorithm 1 does. A footprint is filed only where none covers the pose already. The index
// follows the estimate as PartitionIndex does (rebuilt after a synchronous batch, refreshed a
// few a step after a background batch).

#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "core/geometry/se2.h"
#include "core/geometry/se3.h"
#include "core/map/map_snapshot.h"
#include "mapper-proc/partition_index.h"

namespace evermap::mapper {

using map::Footprint;

class ViewFootprints {
 public:
  using NodePoses = std::function<core::SE3d(int64_t)>;
  ViewFootprints(const core::PlanarGrid& grid, int refresh_per_step)
      : grid_(grid), refresh_per_step_(refresh_per_step) {}

  // The node of the closest footprint made before `before_session` that covers the pose.
  std::optional<int64_t> nodeAt(const core::SE3d& world_T_body, int floor,
                                int before_session) const;
  // Files a footprint of f.node at world_T_view (its node's pose times f.node_T_view) on the
  // node's floor, unless one covers that pose already; true when filed.
  bool add(const Footprint& f, const core::SE3d& world_T_view, int floor);
  // A stored footprint filed as it was made, so that the footprints keep their order and their
  // store rows.
  void restore(const Footprint& f, const core::SE3d& world_T_view, int floor);
  // Node `id` is no place of the map any more (a quarantined session's): its footprints go.
  void forget(int64_t id);
  // Every footprint re-filed at its node's estimate.
  void rebuild(const NodePoses& poses);
  // After a background batch step: re-file refresh_per_step footprints at each refresh().
  void startRefresh() { refresh_next_ = 0; }
  bool refresh(const NodePoses& poses);

  const std::vector<Footprint>& all() const { return footprints_; }

 private:
  void refile(size_t k, const NodePoses& poses);

  core::PlanarGrid grid_;
  int refresh_per_step_;
  std::vector<Footprint> footprints_;
  struct Filed {
    core::SE2d world;  // the estimate when last filed
    core::PlanarCell cell;
  };
  std::vector<Filed> filed_;  // by footprint index
  // The footprints of each cell, but those of forgotten nodes.
  std::unordered_map<core::PlanarCell, std::vector<size_t>, core::PlanarCellHash> cells_;
  std::unordered_set<int64_t> forgotten_nodes_;
  size_t refresh_next_ = SIZE_MAX;
};

}  // namespace evermap::mapper
