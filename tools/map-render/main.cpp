// evermap-map-render: draws a map store (mapper-proc's SQLite file) with its floors stacked,
// like the paper's Fig. 1: nodes coloured by session, odometry and loop-closure edges, and
// optionally the ground truth, aligned to the map through the nodes' keyframe times.
// Exit status: 0 ok, 1 bad input, 2 bad command line.

#include <algorithm>
#include <cstdio>
#include <map>
#include <string>

#include "core/common/command_line.h"
#include "mapper-proc/map_store.h"
#include "tools/eval/alignment.h"
#include "tools/eval/association.h"
#include "tools/eval/map_figure.h"
#include "tools/eval/trajectory.h"

namespace {

using namespace evermap;

int fail(const std::string& message) {
  std::fprintf(stderr, "evermap-map-render: %s\n", message.c_str());
  return 1;
}

}  // namespace

int main(int argc, char** argv) {
  std::string store_file, out_file, gt_file, title;
  eval::MapFigureOptions options;
  CommandLine cli("evermap-map-render",
                  "Draws a map store with its floors stacked (PNG or SVG by the extension).");
  cli.value("--store", &store_file, "MAP.db", "the map store (mapper-proc --store)", true);
  cli.value("--out", &out_file, "FIG", "the figure to write, .png or .svg", true);
  cli.value("--gt", &gt_file, "GT.tum", "ground truth (TUM) drawn under the map, aligned by time");
  cli.value("--title", &title, "TEXT", "the figure's title");
  cli.value("--azimuth", &options.azimuth_deg, "DEG", "turn of the horizontal plane (-30)")
      .min(-360)
      .max(360);
  cli.value("--floor-spacing", &options.floor_spacing, "F",
            "floor spacing as a fraction of the map's extent (0.35)")
      .min(0)
      .max(10);
  cli.value("--width", &options.width_px, "PX", "image width (1200)").min(16).max(20000);
  cli.value("--height", &options.height_px, "PX", "image height (1000)").min(16).max(20000);
  if (const int code = cli.parseOrExit(argc, argv); code >= 0) return code;

  auto store = mapper::MapStore::open(store_file);
  if (!store) return fail(store.error().message);
  auto snapshot = store->load();
  if (!snapshot) return fail(snapshot.error().message);

  eval::MapFigure figure;
  eval::Trajectory nodes_by_time;
  nodes_by_time.source = store_file;
  std::map<int64_t, size_t> index_of;
  for (const mapper::StoredNode& n : snapshot->nodes) {
    index_of[n.node.id] = figure.nodes.size();
    figure.nodes.push_back({n.world_T_body.translation(), n.node.floor, n.node.session});
    nodes_by_time.poses.push_back({n.node.keyframe_utime * 1000, n.world_T_body});
  }
  // One edge per node pair (the merged factor); a loop closure when any constraint of the
  // pair is one.
  size_t rejected = 0, constraints = 0;
  std::map<std::pair<size_t, size_t>, bool> pairs;
  for (const mapper::StoredEdge& e : snapshot->edges) {
    if (!e.constraint.accepted) {
      ++rejected;
      continue;
    }
    ++constraints;
    const auto a = index_of.find(e.constraint.from), b = index_of.find(e.constraint.to);
    if (a == index_of.end() || b == index_of.end()) {
      return fail(store_file + ": edge " + std::to_string(e.edge_id) + " refers to a missing node");
    }
    const auto key = std::minmax(a->second, b->second);
    pairs[key] = pairs[key] || e.constraint.kind == mapper::ConstraintKind::kLoop;
  }
  for (const auto& [key, loop] : pairs) figure.edges.push_back({key.first, key.second, loop});

  if (!gt_file.empty()) {
    auto gt = eval::readTum(gt_file);
    if (!gt) return fail(gt.error().message);
    // Nodes are keyframes, so their times are ground-truth times (to the simulator's rate).
    std::sort(nodes_by_time.poses.begin(), nodes_by_time.poses.end(),
              [](const auto& a, const auto& b) { return a.t_ns < b.t_ns; });
    eval::AssociationOptions assoc;
    assoc.max_dt_s = 0.05;
    auto pairs = eval::associate(*gt, nodes_by_time, assoc);
    if (!pairs) return fail(pairs.error().message);
    auto aligned = eval::alignTrajectories(pairs->gt, pairs->est, eval::AlignmentMode::kSE3);
    if (!aligned) return fail(gt_file + ": " + aligned.error().message);
    const core::SE3d est_T_gt = aligned->gt_S_est.rigid.inverse();
    for (const auto& p : gt->poses)
      figure.reference.push_back(est_T_gt * p.world_T_body.translation());
  }

  options.title = title.empty() ? "map " + store_file : title;
  char subtitle[160];
  eval::MapFigureSummary summary;
  auto canvas = eval::drawMapFigure(figure, options, &summary);
  if (!canvas) return fail(store_file + ": " + canvas.error().message);
  std::snprintf(subtitle, sizeof subtitle,
                "%zu nodes, %zu edges (%zu with loop closures; %zu constraints, %zu rejected), "
                "%zu floors, %zu sessions",
                figure.nodes.size(), figure.edges.size(), summary.loop_closures, constraints,
                rejected, summary.floors, summary.sessions);
  options.subtitle = subtitle;
  canvas = eval::drawMapFigure(figure, options);
  if (!canvas) return fail(canvas.error().message);
  if (Status s = canvas->save(out_file); !s) return fail(s.error().message);
  std::printf("%s: %s\n", out_file.c_str(), subtitle);
  return 0;
}
