#include "tools/sim/request_load.h"

#include <cmath>

namespace evermap::sim {

RequestLoad::RequestLoad(RegistrationOracle& oracle, const RequestLoadOptions& options)
    : oracle_(oracle), o_(options) {
  grid_.cell_size_m = options.cell_size_m;
  grid_.heading_bins = options.heading_bins;
}

void RequestLoad::onKeyframe(const KeyframeTruth& k) {
  oracle_.addKeyframe(k);
  if (k.floor < 0) return;
  const Vec3 axis = k.world_T_cam.so3() * Vec3::UnitZ();  // optical axis
  const Vec3& p = k.world_T_cam.translation();
  const core::PlanarCell cell =
      grid_.cellOf(core::SE2d(p.x(), p.y(), std::atan2(axis.y(), axis.x())), k.floor);
  const auto it = cells_.find(cell);
  if (it == cells_.end()) {
    node_added_t n{};
    n.utime = k.utime;
    n.node_id = next_node_id_++;
    n.keyframe_utime = k.utime;
    n.floor = k.floor;
    n.session = k.session;
    oracle_.addNode(n);
    cells_.emplace(cell, n.node_id);
    ++summary_.nodes_added;
    return;
  }
  if (static_cast<double>(k.utime - last_request_utime_) < 1e6 / o_.request_rate_hz) return;
  last_request_utime_ = k.utime;
  register_request_t r{};
  r.utime = k.utime;
  r.request_id = next_request_id_++;
  r.keyframe_utime = k.utime;
  r.mode = register_request_t::MODE_NODE;
  r.target_node_id = it->second;
  r.floor = k.floor;
  r.session = k.session;
  ++summary_.node_requests;
  if (oracle_.answer(r).status == register_result_t::STATUS_OK) return;
  r.request_id = next_request_id_++;
  r.mode = register_request_t::MODE_GLOBAL;
  r.target_node_id = -1;
  ++summary_.global_requests;
  (void)oracle_.answer(r);
}

}  // namespace evermap::sim
