// evermap-pipeline-eval: the end-of-run evaluation of a map against the ground truth of a
// simulated run (tools/pipeline-eval/map_evaluation.h): node ATE, edges, floors, sessions, and from
// a recorded log also the live POSE ATE and the last MAPPER_STATS; with --localization-log, a
// localization run recorded live against the truth (localization_log.h). Exit status: 0 done
// (and within --max-ate), 1 bad input or ATE over --max-ate, 2 bad usage.

#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "core/common/atomic_write.h"
#include "core/common/command_line.h"
#include "core/common/option_fields.h"
#include "tools/eval/trajectory.h"
#include "tools/pipeline-eval/localization_log.h"
#include "tools/pipeline-eval/map_evaluation.h"

namespace {

using namespace evermap;

// The evaluation's one setting (--help lists it, --print-config prints it).
struct PipelineEvalOptions {
  double max_ate_m = 0.0;
  void declareOptions(OptionList& o) {
    o.add("max_ate_m", &max_ate_m, "m", "exit 1 when the node ATE rmse exceeds this (0: no limit)")
        .min(0);
  }
};

struct EvalArgs {
  std::string run, log, store, json, poses_tum, localization_log;
  std::vector<std::string> truth_logs;
  PipelineEvalOptions options;
};

int fail(const Error& e) {
  std::fprintf(stderr, "evermap-pipeline-eval: %s\n", e.message.c_str());
  return 1;
}

// -1 to run, else the exit status (usage and errors already printed).
int parseCommandLine(int argc, char** argv, EvalArgs* a) {
  CommandLine cli("evermap-pipeline-eval",
                  "Compares a map with the ground truth of a run (evermap-sim-measure --out, or "
                  "logs with GROUND_TRUTH).");
  cli.value("--run", &a->run, "DIR",
            "the run folder of evermap-sim-measure: session-NN.tum and run.sim.txt");
  cli.repeated(
      "--truth-log", &a->truth_logs, "LOG",
      "instead of --run: LCM logs with GROUND_TRUTH (evermap-sim-render, the data-set converters)");
  cli.value("--log", &a->log, "LOG",
            "an LCM log recorded from the pipeline (last MAP_GRAPH, POSE, MAPPER_STATS)");
  cli.value("--store", &a->store, "MAP.db", "a map store instead of a log");
  cli.options(&a->options);
  cli.alias("--max-ate", "max_ate_m", "M");
  cli.value("--json", &a->json, "OUT.json", "also write the figures as JSON");
  cli.value("--poses-tum", &a->poses_tum, "OUT.tum",
            "write the live POSE trajectory of --log as TUM (for evermap-eval and its plot)");
  cli.value("--localization-log", &a->localization_log, "LOG",
            "also a localization run against the map, recorded live (LOCALIZATION and the "
            "replayed session's GROUND_TRUTH): its frames localized and their error");
  if (const int code = cli.parseOrExit(argc, argv); code >= 0) return code;
  if (a->log.empty() == a->store.empty()) {
    std::fprintf(stderr, "evermap-pipeline-eval: give exactly one of --log and --store\n%s",
                 cli.usage().c_str());
    return 2;
  }
  if (a->run.empty() == a->truth_logs.empty()) {
    std::fprintf(stderr, "evermap-pipeline-eval: give exactly one of --run and --truth-log\n%s",
                 cli.usage().c_str());
    return 2;
  }
  return -1;
}

// The map (and from a log, the live poses and counts) of --log or --store.
Expected<mapper::RecordedRun> readRecorded(const EvalArgs& a) {
  if (!a.log.empty()) return mapper::readRecordedRun(a.log);
  auto m = mapper::mapFromStore(a.store);
  if (!m) return m.error();
  mapper::RecordedRun recorded;
  recorded.map = std::move(*m);
  return recorded;
}

void printLogCounts(const mapper::RecordedRun& recorded) {
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

// --poses-tum: the live POSE trajectory of the log.
Status writePoses(const EvalArgs& a, const mapper::RecordedRun& recorded) {
  if (recorded.poses.empty())
    return Error{a.log.empty() ? "--poses-tum needs --log" : a.log + ": no POSE message"};
  eval::Trajectory trajectory;
  trajectory.source = a.log;
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
  return eval::writeTum(trajectory, a.poses_tum);
}

// --localization-log: the localized poses against the replayed session's truth, the map put in
// the truth's frame by its nodes.
Status printLocalization(const EvalArgs& a, const mapper::EvalMap& map,
                         const mapper::RunTruth& truth) {
  auto recorded = mapper::readRecordedLocalization(a.localization_log);
  if (!recorded) return recorded.error();
  auto truth_S_map = mapper::mapInTruth(map, truth);
  if (!truth_S_map) return truth_S_map.error();
  if (recorded->truth.empty())
    return Error{a.localization_log + ": no GROUND_TRUTH message (record it with LOCALIZATION)"};
  const eval::LocalizationAccuracy bounds;  // false beyond its false_m or false_deg
  const eval::LocalizationAccuracy l = eval::evaluateLocalization(
      recorded->poses, *truth_S_map, recorded->truth, mapper::storedNodesInTruth(map, truth),
      bounds.false_m, bounds.false_deg);
  const double pct =
      l.poses > 0 ? 100.0 * static_cast<double>(l.localized) / static_cast<double>(l.poses) : 0.0;
  std::printf(
      "localization frames %lld localized_frames %lld (%.1f %%) first_localized_s %.2f "
      "undecodable %lld\n%s",
      static_cast<long long>(l.poses), static_cast<long long>(l.localized), pct,
      l.first_localized_s, static_cast<long long>(recorded->undecodable),
      eval::truthLine(l).c_str());
  return Ok{};
}

}  // namespace

int main(int argc, char** argv) {
  EvalArgs a;
  if (const int code = parseCommandLine(argc, argv, &a); code >= 0) return code;
  std::vector<std::filesystem::path> truth_files(a.truth_logs.begin(), a.truth_logs.end());
  auto truth = a.run.empty() ? mapper::readLogTruth(truth_files) : mapper::readRunTruth(a.run);
  if (!truth) return fail(truth.error());
  auto recorded = readRecorded(a);
  if (!recorded) return fail(recorded.error());
  auto e = mapper::evaluateMap(recorded->map, *truth, recorded->poses);
  if (!e) return fail(e.error());
  std::printf("%s", e->text().c_str());
  if (!a.log.empty()) printLogCounts(*recorded);
  if (!a.json.empty()) {
    if (Status s = writeFileAtomically(a.json, e->json()); !s) return fail(s.error());
  }
  if (!a.poses_tum.empty()) {
    if (Status s = writePoses(a, *recorded); !s) return fail(s.error());
  }
  if (!a.localization_log.empty()) {
    if (Status s = printLocalization(a, recorded->map, *truth); !s) return fail(s.error());
  }
  if (a.options.max_ate_m > 0.0 &&
      !(e->ate_rmse_m <= a.options.max_ate_m)) {  // NaN (no node ATE) fails too
    std::fprintf(stderr, "evermap-pipeline-eval: node ATE rmse %.3f m exceeds %.3f m\n",
                 e->ate_rmse_m, a.options.max_ate_m);
    return 1;
  }
  return 0;
}
