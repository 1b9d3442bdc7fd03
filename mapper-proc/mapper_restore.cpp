// A mapper continuing a stored map (mapper.h, restore()): the stored nodes and constraints
// replayed into the graph, and where tracking starts: lost, or resumed from the saved
// tracking state (warm_restart.h).

#include <algorithm>
#include <map>

#include "core/solver/pose_factors.h"
#include "mapper-proc/mapper.h"

namespace evermap::mapper {

Status Mapper::restore(const MapSnapshot& map) {
  if (!nodes_.empty() || floors_.known())
    return Error{"mapper: restore: the mapper already holds a map"};
  const std::map<int, double> floors(map.floors.begin(), map.floors.end());
  int max_session = -1;
  Status s = restoreNodes(map, floors, &max_session);
  if (s) s = restoreEdges(map);
  if (s) anchorComponents(map);
  if (!s) {
    // A map that fails half-way leaves the mapper as it was: empty.
    nodes_.clear();
    schedule_.discard();
    constraints_ = ConstraintSet(o_.consistency_gate);
    stats_ = MapperStats{};
    return s;
  }
  if (nodes_.empty()) return Ok{};
  flushSolver();
  for (const Footprint& f : map.footprints)
    footprints_.restore(f, nodePose(f.node) * f.node_T_view,
                        nodes_[static_cast<size_t>(f.node)].floor);
  const int64_t factors = stats_.factors;
  stats_ = MapperStats{};
  stats_.factors = factors;
  const auto n_nodes = static_cast<int64_t>(nodes_.size());
  stats_.restored_nodes = n_nodes;
  stats_.restored_constraints = static_cast<int64_t>(map.edges.size());
  session_ = max_session + 1;
  first_session_ = session_;
  active_ = n_nodes - 1;
  map_confirmed_ = true;  // a stored map is the operator's
  lost_ = true;           // where the robot is on this map is unknown until a global registration
  // ... and so is its floor, unless a FLOOR message says it (a session's start, a ride's
  // end): a mapper-proc restarted mid-session gets none. The guess is the floor of the newest
  // node (where the robot was when the map was saved); every other global search covers
  // every floor, and the relocalisation's node confirms it (sendRequest).
  int64_t newest = 0;
  for (const MapperNode& n : nodes_)
    if (n.keyframe_utime >= nodes_[static_cast<size_t>(newest)].keyframe_utime) newest = n.id;
  const MapperNode& newest_node = nodes_[static_cast<size_t>(newest)];
  floors_.restore(floors, newest_node.floor);
  for (const MapperNode& n : nodes_) floors_.nodesOn(n.floor, 1);
  warm_.arm(map.tracking, n_nodes, newest_node.keyframe_utime, stats_);
  return Ok{};
}

Status Mapper::restoreNodes(const MapSnapshot& map, const std::map<int, double>& floors,
                            int* max_session) {
  for (const auto& [session, start] : map.sessions) *max_session = std::max(*max_session, session);
  // Mappers are named in map_saved by their first session; a warm-restarted one continues an
  // older session and adds none, so the next name is past the names as well.
  *max_session = std::max(*max_session, map.max_saved_mapper);
  for (size_t k = 0; k < map.nodes.size(); ++k) {
    const StoredNode& n = map.nodes[k];
    if (n.node.id != static_cast<int64_t>(k))
      return makeError("mapper: restore: node ", n.node.id, " where node ", k, " was expected");
    *max_session = std::max(*max_session, n.node.session);
    schedule_.addVariable(n.node.id, n.world_T_body);
    if (k == 0)
      addOriginPrior(0, n.world_T_body);  // the origin stays where the first session put it
    const auto height = floors.find(n.node.floor);
    if (o_.height_factors && height != floors.end()) {
      schedule_.addFactor(std::make_shared<solver::HeightFactor>(n.node.id, height->second, 0.02));
    }
    MapperNode node = n.node;
    if (node.attitude && !(o_.attitude_factors && addAttitudeFactor(node.id, *node.attitude)))
      node.attitude.reset();
    nodes_.push_back(node);
  }
  return Ok{};
}

Status Mapper::restoreEdges(const MapSnapshot& map) {
  const auto n_nodes = static_cast<int64_t>(nodes_.size());
  for (size_t k = 0; k < map.edges.size(); ++k) {
    const Constraint& c = map.edges[k].constraint;
    // In the order they were made (a fold comes before its pair's later constraints).
    if ((k > 0 && map.edges[k].edge_id <= map.edges[k - 1].edge_id) || c.from < 0 || c.to < 0 ||
        c.from >= n_nodes || c.to >= n_nodes || c.from == c.to) {
      return makeError("mapper: restore: edge ", map.edges[k].edge_id, " (", c.from, " -> ", c.to,
                       ") is out of order or names an unknown node");
    }
    // As the live mapper added it: closures of the reduced graph passed the map gate.
    addConstraint(c.from, c.to, c.from_T_to, c.kind, c.utime, o_.map_gate > 0 && !o_.full_graph);
  }
  return Ok{};
}

void Mapper::anchorComponents(const MapSnapshot& map) {
  // Union-find over the stored constraints; a part no constraint ties to node 0 (a session
  // that started the map afresh after a quarantine, startSession) gets an origin prior at its
  // first node, as it had when it was made.
  std::vector<int64_t> root(nodes_.size());
  for (size_t k = 0; k < root.size(); ++k) root[k] = static_cast<int64_t>(k);
  auto find = [&](int64_t k) {
    while (root[static_cast<size_t>(k)] != k)
      k = root[static_cast<size_t>(k)] = root[static_cast<size_t>(root[static_cast<size_t>(k)])];
    return k;
  };
  for (const StoredEdge& e : map.edges) {
    const int64_t a = find(e.constraint.from), b = find(e.constraint.to);
    root[static_cast<size_t>(std::max(a, b))] = std::min(a, b);
  }
  for (size_t k = 1; k < root.size(); ++k)
    if (find(static_cast<int64_t>(k)) == static_cast<int64_t>(k))
      addOriginPrior(static_cast<int64_t>(k), map.nodes[k].world_T_body);
}

void Mapper::resume(const WarmRestart::Resume& r) {
  const TrackingState& s = r.state;
  active_ = s.active_node;
  session_ = s.session;
  session_start_utime_ = s.session_start_utime;
  floors_.placeOn(s.floor, std::nullopt);
  // The first VO frame after the restart is placed where this estimate has the body (its
  // reference is unknown to the new tracker: reanchored), so no motion is applied twice.
  tracker_.reset(r.active_T_body);
  lost_ = false;
  relocalize_ = false;
  relocalization_candidate_.reset();
  recovery_.rejected().reset();
}

std::optional<TrackingState> Mapper::trackingState() const {
  if (lost_ || active_ < 0 || nodes_.empty() || tracker_.lastUtime() < 0) return std::nullopt;
  TrackingState s;
  s.utime = tracker_.lastUtime();
  s.session = session_;
  s.session_start_utime = session_start_utime_;
  s.active_node = active_;
  s.floor = floors_.floor();
  s.in_elevator = floors_.inElevator();
  s.active_T_body = tracker_.delta();
  s.odometry = tracker_.odometryAtDelta();
  s.wheel = tracker_.wheelOdometryAt(tracker_.deltaUtime());
  return s;
}

}  // namespace evermap::mapper
