// evermap-mapper-run: the offline runner. Simulates a measurement-level run (a sim config as
// evermap-sim-measure reads it), maps it with the reduced pose graph, the full pose graph or
// both in one process with the registration oracle, and prints nodes, constraints, ATE and
// per-component timing. With --store it continues the map the file holds (docs/mapper.md).
// Exit status: 0 ok, 1 bad input, 2 bad command line.

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "core/common/command_line.h"
#include "core/common/key_value_file.h"
#include "mapper-proc/map_store.h"
#include "mapper-proc/mapper_config.h"
#include "tools/eval/plot.h"
#include "tools/mapper-run/offline_run.h"

namespace {

using evermap::eval::ChartSeries;
using evermap::mapper::OfflineRunSummary;

bool parseSessions(const std::string& v, int* a, int* b) {
  char* end = nullptr;
  *a = static_cast<int>(std::strtol(v.c_str(), &end, 10));
  if (end == v.c_str() || *a < 0) return false;
  if (*end == 0) {
    *b = *a;
    return true;
  }
  if (*end != '-') return false;
  const char* rest = end + 1;
  *b = static_cast<int>(std::strtol(rest, &end, 10));
  return end != rest && *end == 0 && *b >= *a;
}

int checkStore(const std::string& file) {
  if (!std::filesystem::exists(file)) {
    std::fprintf(stderr, "evermap-mapper-run: %s: no such file\n", file.c_str());
    return 1;
  }
  auto store =
      evermap::mapper::MapStore::open(file, evermap::mapper::MapStoreOptions{.read_only = true});
  if (!store) {
    std::fprintf(stderr, "evermap-mapper-run: %s\n", store.error().message.c_str());
    return 1;
  }
  if (auto s = store->integrityCheck(); !s) {
    std::fprintf(stderr, "evermap-mapper-run: %s\n", s.error().message.c_str());
    return 1;
  }
  auto snap = store->load();
  if (!snap) {
    std::fprintf(stderr, "evermap-mapper-run: %s\n", snap.error().message.c_str());
    return 1;
  }
  long long updated = -1;  // the newest keyframe an update stored (a node's or an edge's)
  for (const auto& n : snap->nodes) updated = std::max<long long>(updated, n.node.keyframe_utime);
  for (const auto& e : snap->edges) updated = std::max<long long>(updated, e.constraint.utime);
  std::printf("store ok nodes %zu edges %zu sessions %zu updated_utime %lld tracking_utime %lld\n",
              snap->nodes.size(), snap->edges.size(), snap->sessions.size(), updated,
              snap->tracking ? static_cast<long long>(snap->tracking->utime) : -1LL);
  return 0;
}

void report(const char* what, const evermap::Status& s) {
  if (!s) std::fprintf(stderr, "evermap-mapper-run: %s: %s\n", what, s.error().message.c_str());
}

// The paper's Fig. 4 for one mode: estimate against ground truth, top view, and the map's
// nodes with the floors stacked.
void writeFig4(const std::filesystem::path& dir, const std::string& mode,
               const OfflineRunSummary& s) {
  if (s.trajectory_gt.empty()) return;
  char sub[200];
  std::snprintf(sub, sizeof sub, "%s pose graph: %lld nodes, ATE rmse %.3f m, median %.3f m",
                mode.c_str(), static_cast<long long>(s.nodes), s.ate_rmse_m, s.ate_median_m);
  evermap::eval::TopViewOptions top;
  top.title =
      "Fig. 4: " + mode + " pose graph, trajectory against ground truth (all floors, top view)";
  top.subtitle = sub;
  top.plane = evermap::eval::PlotPlane::kXY;
  report("plot", evermap::eval::writeTopView(dir / ("fig4-" + mode + ".png"), s.trajectory_gt,
                                             s.trajectory_est, top));
  // Floors stacked: an oblique view (u = x + 0.5 y, v = 0.35 y + 3 z) as in the paper's figure.
  auto oblique = [](const std::vector<evermap::core::Vec3>& pts) {
    std::vector<evermap::core::Vec3> out;
    for (const auto& p : pts)
      out.emplace_back(p.x() + 0.5 * p.y(), 0.35 * p.y() + 3.0 * p.z(), 0.0);
    return out;
  };
  top.title =
      "Fig. 4: " + mode + " pose graph, map nodes against ground truth, floors stacked (oblique)";
  top.gt_label = "nodes, ground truth";
  top.est_label = "nodes, estimate";
  if (!s.nodes_gt.empty())
    report("plot", evermap::eval::writeTopView(dir / ("fig4-" + mode + "-floors.svg"),
                                               oblique(s.nodes_gt), oblique(s.nodes_est), top));
}

// The series of the paper's Fig. 7, over all modes run.
struct Fig7Series {
  std::vector<ChartSeries> nodes, step99, step50, parts;
};

// Adds one mode's timeline to the Fig. 7 series.
void addFig7Series(const std::string& mode, const OfflineRunSummary& s, Fig7Series* fig) {
  using evermap::eval::Rgb;
  const std::map<std::string, Rgb> color = {{"reduced", {214, 39, 40}}, {"full", {31, 119, 180}}};
  ChartSeries n{mode + " nodes", {}, color.at(mode), false};
  ChartSeries p99{mode + " p99", {}, color.at(mode), false};
  ChartSeries p50{mode + " median", {}, color.at(mode), true};
  ChartSeries tr{mode + " tracking", {}, color.at(mode), true};
  ChartSeries rg{mode + " registration+partition", {}, color.at(mode), true};
  ChartSeries so{mode + " solver", {}, color.at(mode), false};
  double prev_h = 0.0;
  for (const auto& r : s.timeline) {
    const double hours = r.operating_s / 3600.0;
    n.points.emplace_back(hours, static_cast<double>(r.nodes));
    const double window_s = std::max(1.0, 3600.0 * (hours - prev_h));
    prev_h = hours;
    if (r.steps == 0) continue;
    p99.points.emplace_back(hours, r.step_p99_ms);
    p50.points.emplace_back(hours, r.step_median_ms);
    // Milliseconds of mapper work per second of operation.
    tr.points.emplace_back(hours, 1e3 * r.tracking_s / window_s);
    rg.points.emplace_back(hours, 1e3 * (r.registration_s + r.partition_s) / window_s);
    so.points.emplace_back(hours, 1e3 * r.solver_s / window_s);
  }
  rg.color = {static_cast<uint8_t>(color.at(mode).r / 2),
              static_cast<uint8_t>(color.at(mode).g / 2),
              static_cast<uint8_t>(color.at(mode).b / 2)};
  if (!n.points.empty()) fig->nodes.push_back(n);
  if (!p99.points.empty()) {
    fig->step99.push_back(p99);
    fig->step50.push_back(p50);
    fig->parts.push_back(tr);
    fig->parts.push_back(rg);
    fig->parts.push_back(so);
  }
}

// The paper's Fig. 4 (estimate against ground truth, top view) and Fig. 7 (nodes and mapper
// time against operating time), from the runs made.
void writePlots(const std::filesystem::path& dir,
                const std::map<std::string, OfflineRunSummary>& runs) {
  Fig7Series fig;
  for (const auto& [mode, s] : runs) {
    writeFig4(dir, mode, s);
    addFig7Series(mode, s, &fig);
  }
  evermap::eval::LineChartOptions o;
  o.x_label = "operating time [h]";
  if (!fig.nodes.empty()) {
    o.title = "Fig. 7 (bottom): nodes in the graph against operating time";
    o.y_label = "nodes";
    report("plot", evermap::eval::writeLineChart(dir / "fig7-nodes.svg", fig.nodes, o));
  }
  if (!fig.step99.empty()) {
    o.title =
        "Fig. 7: mapper time per step (request, result handling, new node, solver), per minute";
    o.y_label = "ms per step";
    std::vector<ChartSeries> both = fig.step99;
    both.insert(both.end(), fig.step50.begin(), fig.step50.end());
    report("plot", evermap::eval::writeLineChart(dir / "fig7-update.svg", both, o));
    o.title = "Fig. 7 (top): mapper time per component, per minute of operation";
    o.y_label = "ms per s";
    report("plot", evermap::eval::writeLineChart(dir / "fig7-components.svg", fig.parts, o));
  }
}

// The command line of a run.
struct RunArgs {
  std::string config, mode = "reduced", store, timeline, out, replot, check_store;
  std::vector<std::string> sets;
  double hours = -1.0;
  bool progress = false, print_config = false;
  // The sessions, the store's period, the restart gap and the limits (store_file comes from
  // `store`, for the reduced graph only).
  evermap::mapper::OfflineRunOptions run;
};

// Declares every option of the command line, into `a`.
void declareOptions(evermap::CommandLine* cli, RunArgs* a) {
  using evermap::Error;
  using evermap::Ok;
  using evermap::Status;
  cli->value("--config", &a->config, "SIM.conf",
             "measurement-level simulation settings (config/sim-*.conf)");
  cli->repeated(
      "--set", &a->sets, "key=value",
      "override one setting of the config (e.g. oracle.false_match_rate_node=0.05); mapper.* keys "
      "set the mapper's options (e.g. mapper.map_gate=0)");
  cli->value(
      "--mode",
      [a](const std::string& v) -> Status {
        if (v != "reduced" && v != "full" && v != "both")
          return Error{"expected reduced, full or both"};
        a->mode = v;
        return Ok{};
      },
      "M", "reduced (default), full (a node per step) or both, side by side");
  cli->value("--hours", &a->hours, "H", "override patrol.total_hours").positive();
  cli->value(
      "--sessions",
      [a](const std::string& v) -> Status {
        if (!parseSessions(v, &a->run.first_session, &a->run.last_session))
          return Error{"expected A or A-B, 0 <= A <= B"};
        return Ok{};
      },
      "A-B", "map only sessions A..B of the run (0-based, inclusive)");
  cli->value("--store", &a->store, "MAP.db",
             "the map store (reduced graph only): a map it holds is continued, each update is one "
             "transaction");
  cli->value("--store-period-s", &a->run.store_period_s, "S",
             "at most one store transaction per S seconds of operating time, and one at the end "
             "(0: each update)")
      .min(0);
  cli->value("--restart-gap-s", &a->run.restart_gap_s, "S",
             "continuing a store: skip the messages of S s after its newest state, as a restart "
             "loses them (default 0)")
      .min(0)
      .max(3600);
  cli->value("--stop-after-s", &a->run.stop_after_s, "S",
             "stop mapping after S s of operating time of this run, as a process killed then (0: "
             "to the end)")
      .min(0);
  cli->flag("--progress", &a->progress,
            "print 'committed nodes N edges E rows R utime U' after each store transaction (E "
            "constraints, R rows of map_edges)");
  cli->value("--timeline", &a->timeline, "FILE.csv",
             "per-minute timeline CSV (nodes, per-component time, step cost)");
  cli->value("--out", &a->out, "DIR",
             "timelines, summaries, per-step and per-node errors (steps-M.csv, nodes-M.csv) and "
             "the Fig. 4 / Fig. 7 plots into DIR");
  cli->value("--max-wall-s", &a->run.max_wall_s, "S",
             "stop mapping after S seconds of wall time (per mode); the figures cover the "
             "operating time reached")
      .min(0);
  cli->value("--replot", &a->replot, "DIR",
             "instead of a run: the Fig. 7 plots again from DIR/timeline-reduced.csv and "
             "DIR/timeline-full.csv (either may be missing), runs of the two modes made "
             "separately, drawn side by side");
  cli->flag("--print-config", &a->print_config,
            "print the simulation's and the mapper's settings in effect (after --config and --set) "
            "and exit");
  cli->value("--check-store", &a->check_store, "MAP.db",
             "instead of a run: PRAGMA integrity_check of a map store, then 'store ok nodes N "
             "edges E sessions S updated_utime U' (U: the newest keyframe of a stored node or "
             "edge; a run resumes after it)");
}

// The Fig. 7 plots again from the timelines in `dir`.
int replot(const std::string& dir) {
  std::map<std::string, OfflineRunSummary> runs;
  for (const char* m : {"reduced", "full"}) {
    const auto f = std::filesystem::path(dir) / (std::string("timeline-") + m + ".csv");
    if (!std::filesystem::exists(f)) continue;
    auto rows = evermap::mapper::readTimelineCsv(f);
    if (!rows) {
      std::fprintf(stderr, "evermap-mapper-run: %s\n", rows.error().message.c_str());
      return 1;
    }
    runs[m].timeline = std::move(*rows);
    if (!runs[m].timeline.empty()) runs[m].nodes = runs[m].timeline.back().nodes;
  }
  if (runs.empty()) {
    std::fprintf(stderr, "evermap-mapper-run: %s: no timeline-reduced.csv or timeline-full.csv\n",
                 dir.c_str());
    return 1;
  }
  writePlots(dir, runs);
  return 0;
}

// What a run's options leave to check together; 2 with the error printed, else -1.
int checkRunArgs(const RunArgs& a, const evermap::CommandLine& cli) {
  if (a.config.empty()) {
    std::fprintf(stderr, "evermap-mapper-run: --config is required\n%s", cli.usage().c_str());
    return 2;
  }
  if (a.hours != -1.0 && !(a.hours > 0)) {
    std::fprintf(stderr, "evermap-mapper-run: --hours: must be > 0\n");
    return 2;
  }
  if (a.run.max_wall_s < 0) {
    std::fprintf(stderr, "evermap-mapper-run: --max-wall-s: must be >= 0\n");
    return 2;
  }
  if (!a.timeline.empty() && a.mode == "both") {
    std::fprintf(stderr, "evermap-mapper-run: --timeline takes one mode; use --out DIR for both\n");
    return 2;
  }
  return -1;
}

// The simulation and the mapper's options, from --config and --set (mapper.* keys for the
// mapper, the rest for the simulator).
int loadOptions(const RunArgs& a, evermap::sim::SimOptions* sim,
                evermap::mapper::MapperOptions* mapper_options) {
  using namespace evermap;
  auto file = KeyValueFile::load(a.config, a.sets, "--set");
  if (!file) {
    std::fprintf(stderr, "evermap-mapper-run: %s\n", file.error().message.c_str());
    return 1;
  }
  if (Status s = mapper::readMapperOptions(file->extract("mapper."), mapper_options); !s) {
    std::fprintf(stderr, "evermap-mapper-run: %s\n", s.error().message.c_str());
    return 1;
  }
  auto loaded = sim::loadSimOptions(*file);
  if (!loaded) {
    std::fprintf(stderr, "evermap-mapper-run: %s\n", loaded.error().message.c_str());
    return 1;
  }
  *sim = std::move(*loaded);
  if (a.hours > 0) sim->patrol.total_hours = a.hours;
  return -1;
}

// The run's settings for one mode.
evermap::mapper::OfflineRunOptions runOptions(const RunArgs& a, bool full) {
  evermap::mapper::OfflineRunOptions run = a.run;
  if (!full) run.store_file = a.store;
  if (a.progress) {
    run.on_commit = [](const evermap::mapper::StoreCommit& c) {
      std::printf("committed nodes %lld edges %lld rows %lld utime %lld\n",
                  static_cast<long long>(c.nodes), static_cast<long long>(c.edges),
                  static_cast<long long>(c.edge_rows), static_cast<long long>(c.utime));
      std::fflush(stdout);
    };
  }
  return run;
}

// --timeline and --out's files of one mode's run; 1 on a write error.
int writeRunFiles(const RunArgs& a, const std::string& name, const OfflineRunSummary& summary) {
  using evermap::Status;
  std::vector<std::filesystem::path> csv;
  if (!a.timeline.empty()) csv.emplace_back(a.timeline);
  if (!a.out.empty()) {
    const std::filesystem::path dir(a.out);
    csv.push_back(dir / ("timeline-" + name + ".csv"));
    std::FILE* f = std::fopen((dir / ("summary-" + name + ".txt")).c_str(), "w");
    if (f) {
      std::fputs(summary.text().c_str(), f);
      std::fclose(f);
    }
    if (Status s = evermap::mapper::writeErrorsCsv(dir / ("steps-" + name + ".csv"),
                                                   dir / ("nodes-" + name + ".csv"), summary);
        !s) {
      std::fprintf(stderr, "evermap-mapper-run: %s\n", s.error().message.c_str());
      return 1;
    }
  }
  for (const auto& f : csv) {
    if (Status s = evermap::mapper::writeTimelineCsv(f, summary.timeline); !s) {
      std::fprintf(stderr, "evermap-mapper-run: %s\n", s.error().message.c_str());
      return 1;
    }
  }
  return 0;
}

// The run itself: each mode asked for, its summary printed and its files written.
int run(const RunArgs& a, const evermap::sim::SimOptions& sim,
        const evermap::mapper::MapperOptions& mapper_options) {
  using namespace evermap;
  if (!a.out.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(a.out, ec);
    if (ec) {
      std::fprintf(stderr, "evermap-mapper-run: %s: %s\n", a.out.c_str(), ec.message().c_str());
      return 1;
    }
  }
  std::map<std::string, OfflineRunSummary> runs;
  for (const bool full : {false, true}) {
    if ((full && a.mode == "reduced") || (!full && a.mode == "full")) continue;
    const std::string name = full ? "full" : "reduced";
    mapper::MapperOptions options = mapper_options;
    options.full_graph = full;
    auto summary = mapper::runOffline(sim, options, runOptions(a, full));
    if (!summary) {
      std::fprintf(stderr, "evermap-mapper-run: %s\n", summary.error().message.c_str());
      return 1;
    }
    std::printf("== %s pose graph\n%s", name.c_str(), summary->text().c_str());
    std::fflush(stdout);
    if (writeRunFiles(a, name, *summary) != 0) return 1;
    runs.emplace(name, std::move(*summary));
  }
  if (!a.out.empty()) writePlots(a.out, runs);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  RunArgs a;
  evermap::CommandLine cli(
      "evermap-mapper-run",
      "Simulates a measurement-level run and maps it with the reduced pose graph, the full\n"
      "pose graph or both, with the registration oracle, in one process (docs/mapper.md).\n"
      "Also: --replot DIR, --check-store MAP.db.");
  declareOptions(&cli, &a);
  // The keys --config and --set take, listed in --help: the simulator's and mapper.*.
  evermap::sim::SimOptions listed_sim;
  evermap::mapper::MapperOptions listed_mapper;
  cli.options(&listed_sim);
  cli.options(&listed_mapper, "mapper.");
  if (const int code = cli.parseOrExit(argc, argv); code >= 0) return code;
  if (!a.check_store.empty()) return checkStore(a.check_store);
  if (!a.replot.empty()) return replot(a.replot);
  if (const int code = checkRunArgs(a, cli); code >= 0) return code;
  evermap::sim::SimOptions sim;
  evermap::mapper::MapperOptions mapper_options;
  if (const int code = loadOptions(a, &sim, &mapper_options); code >= 0) return code;
  if (a.print_config) {
    std::printf("%s%s", sim.toConfigText().c_str(),
                evermap::mapper::printMapperOptions(mapper_options).c_str());
    return 0;
  }
  return run(a, sim, mapper_options);
}
