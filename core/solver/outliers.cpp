#include "core/solver/outliers.h"

#include <algorithm>
#include <map>
#include <numbers>
#include <random>

#include "core/solver/graph_problem.h"

namespace evermap::solver {

bool isSyntheticOutlier(const GraphEdge& edge) { return edge.line == 0; }

GraphFile addFalseLoopClosures(const GraphFile& graph, const OutlierOptions& options) {
  GraphFile out = graph;
  if (options.count <= 0 || graph.edges.empty()) return out;
  // When each pose first appears in the edge stream.
  std::map<Key, int> intro;
  std::vector<Key> poses;
  for (int e = 0; e < static_cast<int>(graph.edges.size()); ++e) {
    for (Key k : {graph.edges[e].from, graph.edges[e].to}) {
      if (intro.emplace(k, e).second) poses.push_back(k);
    }
  }
  std::vector<int> loops;
  for (int e = 0; e < static_cast<int>(graph.edges.size()); ++e) {
    if (!isOdometryEdge(graph.edges[e])) loops.push_back(e);
  }
  if (loops.empty()) {
    for (int e = 0; e < static_cast<int>(graph.edges.size()); ++e) loops.push_back(e);
  }
  std::mt19937 rng(options.seed);
  std::uniform_int_distribution<size_t> pick_pose(0, poses.size() - 1);
  std::uniform_int_distribution<size_t> pick_loop(0, loops.size() - 1);
  std::uniform_real_distribution<double> t(-options.translation_range_m, options.translation_range_m);
  std::uniform_real_distribution<double> angle(-std::numbers::pi, std::numbers::pi);
  std::normal_distribution<double> normal(0.0, 1.0);

  std::vector<std::pair<int, GraphEdge>> inserts;  // (insert after edge index, edge)
  while (static_cast<int>(inserts.size()) < options.count && poses.size() > 2) {
    const Key a = poses[pick_pose(rng)];
    const Key b = poses[pick_pose(rng)];
    if (a == b || a - b == 1 || b - a == 1) continue;
    GraphEdge e;
    e.from = std::min(a, b);
    e.to = std::max(a, b);
    e.line = 0;
    e.sqrt_information = graph.edges[loops[pick_loop(rng)]].sqrt_information;
    if (graph.dimension == 2) {
      e.measurement = PoseValue::planar(core::SE2d(t(rng), t(rng), angle(rng)));
    } else {
      Eigen::Quaterniond q(normal(rng), normal(rng), normal(rng), normal(rng));
      e.measurement = PoseValue::spatial(core::SE3d(q.normalized(), core::Vec3(t(rng), t(rng), t(rng))));
    }
    inserts.emplace_back(std::max(intro[a], intro[b]), std::move(e));
  }
  std::stable_sort(inserts.begin(), inserts.end(),
                   [](const auto& x, const auto& y) { return x.first < y.first; });
  out.edges.clear();
  size_t next = 0;
  for (int e = 0; e < static_cast<int>(graph.edges.size()); ++e) {
    out.edges.push_back(graph.edges[e]);
    while (next < inserts.size() && inserts[next].first == e) out.edges.push_back(inserts[next++].second);
  }
  return out;
}

}  // namespace evermap::solver
