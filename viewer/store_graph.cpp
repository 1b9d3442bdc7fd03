#include "viewer/store_graph.h"

#include <map>
#include <system_error>
#include <utility>

#include "core/map/store_file.h"
#include "core/map/store_reader.h"
#include "core/messages/pose_fields.h"

namespace evermap::viewer {
using messages::putPose;

StoredGraph graphFromSnapshot(const map::MapSnapshot& snapshot) {
  StoredGraph out;
  map_graph_t& g = out.graph;
  for (const map::StoredNode& n : snapshot.nodes) {
    map_node_t m{};
    m.node_id = n.node.id;
    m.keyframe_utime = n.node.keyframe_utime;
    putPose(n.world_T_body, m.position, m.orientation);
    m.floor = n.node.floor;
    m.session = n.node.session;
    g.utime = std::max(g.utime, m.keyframe_utime);
    g.nodes.push_back(m);
  }
  std::map<std::pair<int64_t, int64_t>, map_edge_t> pairs;
  for (const map::StoredEdge& e : snapshot.edges) {
    const map::Constraint& c = e.constraint;
    out.rejected += e.folded > 0 ? e.folded_rejected : (c.accepted ? 0 : 1);
    if (e.folded <= 0 && !c.accepted) continue;
    auto [it, inserted] = pairs.try_emplace({c.from, c.to});
    map_edge_t& m = it->second;
    if (inserted) {
      m.from_node = c.from;
      m.to_node = c.to;
      m.type = map_edge_t::TYPE_ODOMETRY;
      putPose(c.from_T_to.mean, m.translation, m.orientation);
    }
    m.num_measurements += e.folded > 0 ? static_cast<int32_t>(e.folded) : 1;
    if (c.kind == map::ConstraintKind::kLoop) m.type = map_edge_t::TYPE_LOOP;
  }
  for (auto& [key, e] : pairs) g.edges.push_back(e);
  for (const auto& [index, height] : snapshot.floors)
    g.floors.push_back(map_floor_t{index, height});
  g.num_nodes = static_cast<int32_t>(g.nodes.size());
  g.num_edges = static_cast<int32_t>(g.edges.size());
  g.num_floors = static_cast<int32_t>(g.floors.size());
  return out;
}

Expected<StoredGraph> loadStoredGraph(const std::filesystem::path& file) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(file, ec))
    return makeError(file.string(), ": no such map store (not a file)");
  auto store = map::StoreFile::open(file, /*read_only=*/true);
  if (!store) return store.error();
  auto snapshot = map::readMap(*store);
  if (!snapshot) return snapshot.error();
  return graphFromSnapshot(*snapshot);
}

}  // namespace evermap::viewer
