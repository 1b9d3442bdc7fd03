// evermap-map-render: draws a map store (mapper-proc's SQLite file) with its floors stacked,
// like the paper's Fig. 1: nodes coloured by session, odometry and loop-closure edges, and
// optionally the ground truth, aligned to the map through the nodes' keyframe times.
// Exit status: 0 ok, 1 bad input, 2 bad command line.

#include <algorithm>
#include <cstdio>
#include <map>
#include <string>

#include "core/common/command_line.h"
#include "core/common/option_fields.h"
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

// The figure's settings (--help lists them, --print-config prints them).
struct RenderOptions {
  eval::MapFigureOptions figure;

  void declareOptions(OptionList& o) {
    o.add("azimuth_deg", &figure.azimuth_deg, "deg", "turn of the horizontal plane").in(-360, 360);
    o.add("floor_spacing", &figure.floor_spacing, "",
          "floor spacing as a fraction of the map's extent")
        .in(0, 10);
    o.add("width_px", &figure.width_px, "px", "image width").in(16, 20000);
    o.add("height_px", &figure.height_px, "px", "image height").in(16, 20000);
  }
};

struct RenderArgs {
  std::string store_file, out_file, gt_file, title;
  RenderOptions options;
};

// -1 to run, else the exit status (usage and errors already printed).
int parseCommandLine(int argc, char** argv, RenderArgs* a) {
  CommandLine cli("evermap-map-render",
                  "Draws a map store with its floors stacked (PNG or SVG by the extension).");
  cli.value("--store", &a->store_file, "MAP.db", "the map store (mapper-proc --store)", true);
  cli.value("--out", &a->out_file, "FIG", "the figure to write, .png or .svg", true);
  cli.value("--gt", &a->gt_file, "GT.tum",
            "ground truth (TUM) drawn under the map, aligned by time");
  cli.value("--title", &a->title, "TEXT", "the figure's title");
  cli.options(&a->options);
  cli.alias("--azimuth", "azimuth_deg", "DEG");
  cli.alias("--floor-spacing", "floor_spacing", "F");
  cli.alias("--width", "width_px", "PX");
  cli.alias("--height", "height_px", "PX");
  return cli.parseOrExit(argc, argv);
}

// The figure's nodes and edges from the store's snapshot, with the nodes' keyframe times.
struct StoreFigure {
  eval::MapFigure figure;
  eval::Trajectory nodes_by_time;
  size_t rejected = 0, constraints = 0;
};

Expected<StoreFigure> figureOfStore(const std::string& store_file) {
  auto store = mapper::MapStore::open(store_file, mapper::MapStoreOptions{.read_only = true});
  if (!store) return store.error();
  auto snapshot = store->load();
  if (!snapshot) return snapshot.error();
  StoreFigure out;
  out.nodes_by_time.source = store_file;
  std::map<int64_t, size_t> index_of;
  for (const mapper::StoredNode& n : snapshot->nodes) {
    index_of[n.node.id] = out.figure.nodes.size();
    out.figure.nodes.push_back({n.world_T_body.translation(), n.node.floor, n.node.session});
    out.nodes_by_time.poses.push_back({n.node.keyframe_utime * 1000, n.world_T_body});
  }
  // One edge per node pair (the merged factor); a loop closure when any constraint of the
  // pair is one.
  std::map<std::pair<size_t, size_t>, bool> pairs;
  for (const mapper::StoredEdge& e : snapshot->edges) {
    if (!e.constraint.accepted) {
      ++out.rejected;
      continue;
    }
    ++out.constraints;
    const auto a = index_of.find(e.constraint.from), b = index_of.find(e.constraint.to);
    if (a == index_of.end() || b == index_of.end()) {
      return makeError(store_file, ": edge ", e.edge_id, " refers to a missing node");
    }
    const auto key = std::minmax(a->second, b->second);
    pairs[key] = pairs[key] || e.constraint.kind == mapper::ConstraintKind::kLoop;
  }
  for (const auto& [key, loop] : pairs) out.figure.edges.push_back({key.first, key.second, loop});
  return out;
}

// The ground truth of `gt_file`, aligned to the map through the nodes' keyframe times, as the
// figure's reference.
Status addReference(const std::string& gt_file, StoreFigure* f) {
  auto gt = eval::readTum(gt_file);
  if (!gt) return gt.error();
  // Nodes are keyframes, so their times are ground-truth times (to the simulator's rate).
  std::sort(f->nodes_by_time.poses.begin(), f->nodes_by_time.poses.end(),
            [](const auto& a, const auto& b) { return a.t_ns < b.t_ns; });
  eval::AssociationOptions assoc;
  assoc.max_dt_s = 0.05;
  auto pairs = eval::associate(*gt, f->nodes_by_time, assoc);
  if (!pairs) return pairs.error();
  auto aligned = eval::alignTrajectories(pairs->gt, pairs->est, eval::AlignmentMode::kSE3);
  if (!aligned) return makeError(gt_file, ": ", aligned.error().message);
  const core::SE3d est_T_gt = aligned->gt_S_est.rigid.inverse();
  for (const auto& p : gt->poses)
    f->figure.reference.push_back(est_T_gt * p.world_T_body.translation());
  return Ok{};
}

}  // namespace

int main(int argc, char** argv) {
  RenderArgs a;
  if (const int code = parseCommandLine(argc, argv, &a); code >= 0) return code;
  auto f = figureOfStore(a.store_file);
  if (!f) return fail(f.error().message);
  if (!a.gt_file.empty()) {
    if (Status s = addReference(a.gt_file, &*f); !s) return fail(s.error().message);
  }
  eval::MapFigureOptions& options = a.options.figure;
  const eval::MapFigure& figure = f->figure;
  options.title = a.title.empty() ? "map " + a.store_file : a.title;
  char subtitle[160];
  eval::MapFigureSummary summary;
  auto canvas = eval::drawMapFigure(figure, options, &summary);
  if (!canvas) return fail(a.store_file + ": " + canvas.error().message);
  std::snprintf(subtitle, sizeof subtitle,
                "%zu nodes, %zu edges (%zu with loop closures; %zu constraints, %zu rejected), "
                "%zu floors, %zu sessions",
                figure.nodes.size(), figure.edges.size(), summary.loop_closures, f->constraints,
                f->rejected, summary.floors, summary.sessions);
  options.subtitle = subtitle;
  canvas = eval::drawMapFigure(figure, options);
  if (!canvas) return fail(canvas.error().message);
  if (Status s = canvas->save(a.out_file); !s) return fail(s.error().message);
  std::printf("%s: %s\n", a.out_file.c_str(), subtitle);
  return 0;
}
