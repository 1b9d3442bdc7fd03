// evermap-pipeline-eval: the end-of-run evaluation of a map against the ground truth of a
// simulated run (tools/pipeline-eval/map_evaluation.h): node ATE, edges, floors, sessions, and from
// a recorded log also the live POSE ATE and the last MAPPER_STATS. Exit status: 0 done (and within
// --max-ate), 1 bad input or ATE over --max-ate, 2 bad usage.

#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "core/common/atomic_write.h"
#include "core/common/command_line.h"
#include "tools/eval/trajectory.h"
#include "tools/pipeline-eval/map_evaluation.h"

int main(int argc, char** argv) {
  using namespace evermap;
  std::string run, log, store, json;
  double max_ate_m = 0.0;
  CommandLine cli("evermap-pipeline-eval",
                  "Compares a map with the ground truth of a run (evermap-sim-measure --out, or "
                  "logs with GROUND_TRUTH).");
  cli.value("--run", &run, "DIR",
            "the run folder of evermap-sim-measure: session-NN.tum and run.sim.txt");
  std::vector<std::string> truth_logs;
  cli.repeated(
      "--truth-log", &truth_logs, "LOG",
      "instead of --run: LCM logs with GROUND_TRUTH (evermap-sim-render, the data-set converters)");
  cli.value("--log", &log, "LOG",
            "an LCM log recorded from the pipeline (last MAP_GRAPH, POSE, MAPPER_STATS)");
  cli.value("--store", &store, "MAP.db", "a map store instead of a log");
  cli.value("--max-ate", &max_ate_m, "M",
            "exit 1 when the node ATE rmse exceeds M metres (0: no limit)")
      .min(0);
  cli.value("--json", &json, "OUT.json", "also write the figures as JSON");
  std::string poses_tum;
  cli.value("--poses-tum", &poses_tum, "OUT.tum",
            "write the live POSE trajectory of --log as TUM (for evermap-eval and its plot)");
  if (const int code = cli.parseOrExit(argc, argv); code >= 0) return code;
  if (log.empty() == store.empty()) {
    std::fprintf(stderr, "evermap-pipeline-eval: give exactly one of --log and --store\n%s",
                 cli.usage().c_str());
    return 2;
  }
  auto fail = [](const Error& e) {
    std::fprintf(stderr, "evermap-pipeline-eval: %s\n", e.message.c_str());
    return 1;
  };
  if (run.empty() == truth_logs.empty()) {
    std::fprintf(stderr, "evermap-pipeline-eval: give exactly one of --run and --truth-log\n%s",
                 cli.usage().c_str());
    return 2;
  }
  std::vector<std::filesystem::path> truth_files(truth_logs.begin(), truth_logs.end());
  auto truth = run.empty() ? mapper::readLogTruth(truth_files) : mapper::readRunTruth(run);
  if (!truth) return fail(truth.error());
  mapper::RecordedRun recorded;
  if (!log.empty()) {
    auto r = mapper::readRecordedRun(log);
    if (!r) return fail(r.error());
    recorded = std::move(*r);
  } else {
    auto m = mapper::mapFromStore(store);
    if (!m) return fail(m.error());
    recorded.map = std::move(*m);
  }
  auto e = mapper::evaluateMap(recorded.map, *truth, recorded.poses);
  if (!e) return fail(e.error());
  std::printf("%s", e->text().c_str());
  if (!log.empty()) {
    std::printf("map_graphs_in_log %lld\nundecodable_in_log %lld\n",
                static_cast<long long>(recorded.graphs),
                static_cast<long long>(recorded.undecodable));
    if (recorded.have_stats) {
      const auto& s = recorded.stats;
      std::printf("stats_constraints %lld\nstats_rejected %lld\nstats_dropped_messages %lld\n",
                  static_cast<long long>(s.num_constraints), static_cast<long long>(s.num_rejected),
                  static_cast<long long>(s.num_dropped_messages));
    }
  }
  if (!json.empty()) {
    if (Status s = writeFileAtomically(json, e->json()); !s) return fail(s.error());
  }
  if (!poses_tum.empty()) {
    if (recorded.poses.empty())
      return fail(Error{log.empty() ? "--poses-tum needs --log" : log + ": no POSE message"});
    eval::Trajectory trajectory;
    trajectory.source = log;
    // POSE goes out after a VO frame and after a wheel increment, which may share a stamp:
    // the later message is the newer estimate.
    for (const auto& [utime, world_T_body] : recorded.poses) {
      if (!trajectory.poses.empty() && trajectory.poses.back().t_ns >= utime * 1000) {
        if (trajectory.poses.back().t_ns == utime * 1000)
          trajectory.poses.back().world_T_body = world_T_body;
        continue;
      }
      trajectory.poses.push_back({utime * 1000, world_T_body});
    }
    if (Status s = eval::writeTum(trajectory, poses_tum); !s) return fail(s.error());
  }
  if (max_ate_m > 0.0 && !(e->ate_rmse_m <= max_ate_m)) {  // NaN (no node ATE) fails too
    std::fprintf(stderr, "evermap-pipeline-eval: node ATE rmse %.3f m exceeds %.3f m\n",
                 e->ate_rmse_m, max_ate_m);
    return 1;
  }
  return 0;
}
