#include "mapper-proc/view_footprints.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace evermap::mapper {

std::optional<int64_t> ViewFootprints::nodeAt(const core::SE3d& world_T_body, int floor,
                                              int before_session) const {
  // Covered: within half a cell and half a heading sector (so filed in a neighbouring cell
  // and sector at most, which are searched), whatever cell edge lies between. The closest
  // footprint (distance and turn, each over its bound) names the node.
  const core::SE2d p = core::toPlanar(world_T_body);
  const double radius_m = 0.5 * grid_.cell_size_m;
  const double heading_rad = std::numbers::pi / grid_.heading_bins;
  std::optional<int64_t> best;
  double best_score = 2.0;
  grid_.forEachNear(grid_.cellOf(p, floor), 1, 1, [&](const core::PlanarCell& n) {
    auto it = cells_.find(n);
    if (it == cells_.end()) return;
    for (size_t k : it->second) {
      if (footprints_[k].session >= before_session) continue;
      const core::SE2d& q = filed_[k].world;
      const double d = std::hypot(q.x() - p.x(), q.y() - p.y()) / radius_m;
      const double a = PartitionIndex::headingApartRad(q, p) / heading_rad;
      if (d > 1.0 || a > 1.0 || d + a >= best_score) continue;
      best_score = d + a;
      best = footprints_[k].node;
    }
  });
  return best;
}

bool ViewFootprints::add(const Footprint& f, const core::SE3d& world_T_view, int floor) {
  if (forgotten_nodes_.count(f.node)) return false;
  if (nodeAt(world_T_view, floor, std::numeric_limits<int>::max())) return false;
  restore(f, world_T_view, floor);
  return true;
}

void ViewFootprints::restore(const Footprint& f, const core::SE3d& world_T_view, int floor) {
  const core::SE2d p = core::toPlanar(world_T_view);
  footprints_.push_back(f);
  filed_.push_back(Filed{p, grid_.cellOf(p, floor)});
  if (!forgotten_nodes_.count(f.node)) cells_[filed_.back().cell].push_back(footprints_.size() - 1);
}

void ViewFootprints::forget(int64_t id) {
  if (!forgotten_nodes_.insert(id).second) return;
  for (size_t k = 0; k < footprints_.size(); ++k) {
    if (footprints_[k].node != id) continue;
    auto& ids = cells_[filed_[k].cell];
    ids.erase(std::find(ids.begin(), ids.end(), k));
  }
}

void ViewFootprints::refile(size_t k, const NodePoses& poses) {
  const Footprint& f = footprints_[k];
  if (forgotten_nodes_.count(f.node)) return;
  filed_[k].world = core::toPlanar(poses(f.node) * f.node_T_view);
  const core::PlanarCell cell = grid_.cellOf(filed_[k].world, filed_[k].cell.floor);
  if (cell == filed_[k].cell) return;
  auto& old = cells_[filed_[k].cell];
  old.erase(std::find(old.begin(), old.end(), k));
  auto& ids = cells_[cell];
  ids.insert(std::lower_bound(ids.begin(), ids.end(), k), k);
  filed_[k].cell = cell;
}

void ViewFootprints::rebuild(const NodePoses& poses) {
  for (size_t k = 0; k < footprints_.size(); ++k) refile(k, poses);
  refresh_next_ = SIZE_MAX;
}

bool ViewFootprints::refresh(const NodePoses& poses) {
  if (refresh_next_ >= footprints_.size()) {
    refresh_next_ = SIZE_MAX;
    return false;
  }
  const size_t end =
      std::min(footprints_.size(), refresh_next_ + static_cast<size_t>(refresh_per_step_));
  for (; refresh_next_ < end; ++refresh_next_) refile(refresh_next_, poses);
  if (refresh_next_ >= footprints_.size()) refresh_next_ = SIZE_MAX;
  return true;
}

}  // namespace evermap::mapper
