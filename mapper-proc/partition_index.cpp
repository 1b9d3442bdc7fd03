#include "mapper-proc/partition_index.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace evermap::mapper {

PartitionIndex::PartitionIndex(const Options& options)
    : o_(options), grid_{options.cell_size_m, options.heading_bins} {}

core::PlanarCell PartitionIndex::cellOf(const core::SE3d& world_T_body, int floor) const {
  return grid_.cellOf(core::toPlanar(world_T_body), floor);
}

std::optional<int64_t> PartitionIndex::nodeInCell(const core::PlanarCell& cell,
                                                  int64_t newest_allowed,
                                                  const std::vector<MapperNode>& nodes) const {
  auto it = cells_.find(cell);
  if (it == cells_.end()) return std::nullopt;
  // The most recently added node of the cell (paper section IV-B).
  for (auto id = it->second.rbegin(); id != it->second.rend(); ++id)
    if (nodes[*id].keyframe_utime <= newest_allowed) return *id;
  return std::nullopt;
}

double PartitionIndex::overlapHeadingRad() const {
  return o_.overlap_heading_sectors * 2.0 * std::numbers::pi / o_.heading_bins;
}

double PartitionIndex::headingApartRad(const core::SE2d& a, const core::SE2d& b) {
  return std::abs(std::remainder(a.theta() - b.theta(), 2.0 * std::numbers::pi));
}

std::optional<int64_t> PartitionIndex::overlappingNode(
    const core::SE3d& world_T_body, int floor, int64_t newest_allowed,
    const std::vector<MapperNode>& nodes, const solver::IncrementalSolver& solver) const {
  return closestNode(
      world_T_body, floor, newest_allowed, nodes,
      [&solver](int64_t id) { return solver.estimate(id).se3; },
      o_.overlap_radius_cells * o_.cell_size_m, overlapHeadingRad());
}

std::optional<int64_t> PartitionIndex::closestNode(const core::SE3d& world_T_body, int floor,
                                                   int64_t newest_allowed,
                                                   const std::vector<MapperNode>& nodes,
                                                   const NodePoses& poses, double radius_m,
                                                   double heading_rad) const {
  if (!(radius_m > 0.0) || !(heading_rad > 0.0)) return std::nullopt;
  const core::SE2d p = core::toPlanar(world_T_body);
  const core::PlanarCell c = grid_.cellOf(p, floor);
  std::optional<int64_t> best;
  double best_score = 2.0;
  // The cells and sectors the overlap reaches into: every candidate is filed in one of them.
  const int rings = static_cast<int>(std::ceil(o_.overlap_radius_cells));
  const int sector_rings = static_cast<int>(std::ceil(o_.overlap_heading_sectors));
  grid_.forEachNear(c, rings, sector_rings, [&](const core::PlanarCell& n) {
    auto it = cells_.find(n);
    if (it == cells_.end()) return;
    for (int64_t id : it->second) {
      if (nodes[static_cast<size_t>(id)].keyframe_utime > newest_allowed) continue;
      const core::SE2d q = core::toPlanar(poses(id));
      const double d = std::hypot(q.x() - p.x(), q.y() - p.y()) / radius_m;
      const double a = headingApartRad(q, p) / heading_rad;
      if (d > 1.0 || a > 1.0) continue;
      if (d + a < best_score) {
        best_score = d + a;
        best = id;
      }
    }
  });
  return best;
}

std::optional<int64_t> PartitionIndex::nodeAt(const core::SE3d& world_T_body, int floor,
                                              int64_t newest_allowed,
                                              const std::vector<MapperNode>& nodes,
                                              const solver::IncrementalSolver& solver) const {
  if (auto id = nodeInCell(cellOf(world_T_body, floor), newest_allowed, nodes)) return id;
  return overlappingNode(world_T_body, floor, newest_allowed, nodes, solver);
}

std::optional<int64_t> PartitionIndex::nodeAt(const core::SE3d& world_T_body, int floor,
                                              int64_t newest_allowed,
                                              const std::vector<MapperNode>& nodes,
                                              const NodePoses& poses) const {
  if (auto id = nodeInCell(cellOf(world_T_body, floor), newest_allowed, nodes)) return id;
  return closestNode(world_T_body, floor, newest_allowed, nodes, poses,
                     o_.overlap_radius_cells * o_.cell_size_m, overlapHeadingRad());
}

void PartitionIndex::quarantine(int64_t id) {
  const auto k = static_cast<size_t>(id);
  if (k >= quarantined_.size()) quarantined_.resize(k + 1, false);
  if (quarantined_[k]) return;
  quarantined_[k] = true;
  if (k >= node_cell_.size()) return;
  auto& ids = cells_[node_cell_[k]];
  ids.erase(std::find(ids.begin(), ids.end(), id));
}

void PartitionIndex::file(int64_t id, const core::PlanarCell& cell) {
  const auto k = static_cast<size_t>(id);
  const bool out = k < quarantined_.size() && quarantined_[k];
  if (k < node_cell_.size()) {
    if (node_cell_[k] == cell) return;
    if (!out) {
      auto& old = cells_[node_cell_[k]];
      old.erase(std::find(old.begin(), old.end(), id));
    }
    node_cell_[k] = cell;
  } else {
    node_cell_.push_back(cell);  // nodes are filed first in id order
  }
  if (out) return;
  auto& ids = cells_[cell];
  ids.insert(std::lower_bound(ids.begin(), ids.end(), id), id);
}

void PartitionIndex::rebuild(const std::vector<MapperNode>& nodes, const solver::Values& estimate) {
  cells_.clear();
  node_cell_.clear();
  for (const MapperNode& n : nodes) file(n.id, cellOf(estimate[n.id].se3, n.floor));
  refresh_next_ = SIZE_MAX;
}

bool PartitionIndex::refresh(const std::vector<MapperNode>& nodes,
                             const solver::IncrementalSolver& solver) {
  if (refresh_next_ >= nodes.size()) return false;
  const size_t end =
      std::min(nodes.size(), refresh_next_ + static_cast<size_t>(o_.refresh_per_step));
  for (; refresh_next_ < end; ++refresh_next_) {
    const MapperNode& n = nodes[refresh_next_];
    file(n.id, cellOf(solver.estimate(n.id).se3, n.floor));
  }
  if (refresh_next_ >= nodes.size()) refresh_next_ = SIZE_MAX;
  return true;
}

}  // namespace evermap::mapper
