// evermap-mapper-proc: the reduced pose graph mapper on LCM (DESIGN.md section 1). Parses
// options, opens the map store, wires LCM (LcmNode) and runs the loop; the logic is Mapper.
// Exit status: 0 on SIGINT/SIGTERM, 1 LCM or map store failure, 2 bad command line.

#include <chrono>
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "core/common/command_line.h"
#include "core/common/stop_signals.h"
#include "core/messages/key_option.h"
#include "mapper-proc/lcm_node.h"
#include "mapper-proc/localizer_node.h"
#include "mapper-proc/map_store.h"
#include "mapper-proc/mapper.h"
#include "mapper-proc/mapper_config.h"

namespace {

using namespace evermap;

struct Settings {
  // The camera mounting comes from STEREO_CALIB (LcmNode).
  mapper::MapperOptions options;
  mapper::LcmNodeOptions node_options;
  std::string url, store_file, key_file;
  bool quiet = false, localize = false;
  double progress_s = 0.0;
};

// The command line; -1 to run, else the exit status.
int parse(int argc, char** argv, Settings* s) {
  CommandLine cli(
      "evermap-mapper-proc",
      "The reduced pose graph mapper on LCM: STEREO_CALIB, VO_DELTA, WHEEL_ODOM, ATTITUDE,\n"
      "FLOOR and REGISTER_RESULT in; REGISTER_REQUEST, NODE_ADDED, POSE, MAP_GRAPH, MAPPER_STATS "
      "out.");
  bool full_graph = false;
  cli.flag("--full-graph", &full_graph,
           "a node at every step (the paper's baseline) instead of the reduced graph");
  cli.value("--store", &s->store_file, "MAP.db",
            "write the map store (SQLite) after every update that changes the graph");
  cli.flag("--localize", &s->localize,
           "localize against the map in --store instead of mapping: the store read once, "
           "read-only (unchanged); REGISTER_REQUEST, POSE and LOCALIZATION out "
           "(docs/localization.md)");
  cli.value("--graph-period-s", &s->node_options.graph_period_s, "S",
            "MAP_GRAPH after a change at most every S seconds of message time (default 1)")
      .min(0);
  cli.value("--stats-period-s", &s->node_options.stats_period_s, "S",
            "MAPPER_STATS every S seconds of message time (default 1)")
      .min(0);
  cli.value("--time-window-s", &s->node_options.input.time.window_s, "S",
            "refuse a message stamped more than S s from the stream's clock until others confirm "
            "the jump (default 120; 0: off; core/messages/inbox.h)")
      .min(0);
  cli.value("--queue", &s->node_options.input.queue_capacity, "N",
            "messages LCM may queue per subscription (default 10000)")
      .min(1)
      .max(1000000);
  cli.value("--lcm-url", &s->url, "URL", "LCM provider (default: $LCM_DEFAULT_URL)");
  cli.flag("--quiet", &s->quiet, "no summary on exit");
  messages::declareKeyOption(cli, &s->key_file);
  cli.value("--progress-s", &s->progress_s, "S",
            "print a progress line (message time, nodes, constraints, drops) every S s of wall "
            "time while messages arrive (0: none)")
      .min(0);
  cli.options(&s->options, "mapper.");
  cli.check([s, &full_graph]() -> Status {
    s->options.full_graph = full_graph;
    if (s->localize && s->store_file.empty()) return Error("--localize needs --store MAP.db");
    if (s->localize && full_graph) return Error("--localize and --full-graph exclude each other");
    if (Status v = s->options.validate(); !v) return v;
    return s->node_options.validate();
  });
  if (const int code = cli.parseOrExit(argc, argv); code >= 0) return code;
  cli.logChangedOptions();
  return -1;
}

// The store of --store (none without it); exit status 1 printed when it cannot be opened.
Expected<std::optional<mapper::MapStore>> openStore(const std::string& file) {
  if (file.empty()) return std::optional<mapper::MapStore>();
  auto opened = mapper::MapStore::open(file);
  if (!opened) return opened.error();
  return std::optional<mapper::MapStore>(std::move(*opened));
}

// A store that holds a map (a restart after a crash, or a new session over a saved map):
// the mapper continues it, lost until a global registration places it on the map.
Status restoreMap(mapper::MapStore& store, const std::string& file, mapper::Mapper* m) {
  auto held = store.load();
  if (!held) return held.error();
  if (held->nodes.empty()) return Ok{};
  if (Status r = m->restore(*held); !r) return makeError(file, ": ", r.error().message);
  std::printf("evermap-mapper-proc: continuing %s: %zu nodes, %zu constraints restored\n",
              file.c_str(), m->nodes().size(), m->constraints().all().size());
  std::fflush(stdout);
  return Ok{};
}

// Progress is for the person watching, so it runs on the wall clock; the map never sees it.
class Progress {
 public:
  explicit Progress(double period_s) : period_s_(period_s) {}
  void maybePrint(const mapper::LcmNode& node, const mapper::Mapper& m) {
    if (!(period_s_ > 0.0) || node.lastUtime() < 0 || Clock::now() < next_) return;
    const int64_t now_utime = node.lastUtime();
    // Data time mapped so far; a jump of an hour or more (the gap between sessions) is not
    // counted.
    if (previous_utime_ >= 0 && now_utime > previous_utime_) {
      const double step_s = 1e-6 * static_cast<double>(now_utime - previous_utime_);
      if (step_s < 3600.0) data_s_ += step_s;
    }
    previous_utime_ = now_utime;
    next_ = Clock::now() +
            std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(period_s_));
    std::printf(
        "progress: wall %.0f s, data %.0f s, session %d, nodes %zu, "
        "constraints %zu, dropped %lld\n",
        std::chrono::duration<double>(Clock::now() - started_).count(), data_s_, m.session(),
        m.nodes().size(), m.constraints().all().size(),
        static_cast<long long>(node.counts().dropped()));
    std::fflush(stdout);
  }

 private:
  using Clock = std::chrono::steady_clock;
  double period_s_;
  Clock::time_point started_ = Clock::now();
  Clock::time_point next_ = started_;
  int64_t previous_utime_ = -1;
  double data_s_ = 0.0;
};

// Handles LCM until SIGINT/SIGTERM; 0, or 1 when LCM fails.
int runLoop(lcm::LCM& lcm, mapper::LcmNode& node, const mapper::Mapper& m, StopSignals& stop,
            double progress_s) {
  Progress progress(progress_s);
  while (!stop.requested()) {
    const int handled = lcm.handleTimeout(200);
    if (handled < 0) {
      std::fprintf(stderr, "evermap-mapper-proc: LCM failed\n");
      return 1;
    }
    // Idle: whatever changed since the last MAP_GRAPH goes out now (the end of a replay).
    if (handled == 0) node.flush();
    progress.maybePrint(node, m);
  }
  return 0;
}

// --localize: the stored map read once, read-only, and the localizer run on LCM until
// SIGINT/SIGTERM; main's exit status.
int runLocalize(const Settings& settings, StopSignals& stop) {
  mapper::MapStoreOptions read_only;
  read_only.read_only = true;
  auto store = mapper::MapStore::open(settings.store_file, read_only);
  if (!store) {
    std::fprintf(stderr, "evermap-mapper-proc: %s\n", store.error().message.c_str());
    return 1;
  }
  auto map = store->load();
  mapper::Localizer localizer(settings.options);
  const Status loaded = map ? localizer.load(*map) : Status(map.error());
  if (!loaded) {
    std::fprintf(stderr, "evermap-mapper-proc: %s: %s\n", settings.store_file.c_str(),
                 loaded.error().message.c_str());
    return 1;
  }
  std::printf("evermap-mapper-proc: localizing against %s: %zu nodes (read-only)\n",
              settings.store_file.c_str(), localizer.nodes().size());
  std::fflush(stdout);
  lcm::LCM lcm(settings.url);
  if (!lcm.good()) {
    std::fprintf(stderr, "evermap-mapper-proc: cannot start LCM (url \"%s\")\n",
                 settings.url.c_str());
    return 1;
  }
  mapper::LocalizerNode node(lcm, localizer, settings.node_options);
  while (!stop.requested()) {
    if (lcm.handleTimeout(200) < 0) {
      std::fprintf(stderr, "evermap-mapper-proc: LCM failed\n");
      return 1;
    }
  }
  if (!settings.quiet) std::printf("evermap-mapper-proc: %s", node.summary().c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Settings settings;
  if (const int code = parse(argc, argv, &settings); code >= 0) return code;
  // SIGINT/SIGTERM blocked, then polled between LCM waits: before any thread starts (restoring
  // a stored map runs a solver batch, whose background worker would otherwise take the signal
  // and die of it, with no summary and no last flush).
  StopSignals stop;
  auto signer = messages::makeSigner("evermap-mapper-proc", settings.key_file);
  if (!signer) {
    std::fprintf(stderr, "evermap-mapper-proc: %s\n", signer.error().message.c_str());
    return 2;
  }
  settings.node_options.input.signer = *signer;
  if (settings.localize) return runLocalize(settings, stop);
  auto store = openStore(settings.store_file);
  if (!store) {
    std::fprintf(stderr, "evermap-mapper-proc: %s\n", store.error().message.c_str());
    return 1;
  }
  lcm::LCM lcm(settings.url);
  if (!lcm.good()) {
    std::fprintf(stderr, "evermap-mapper-proc: cannot start LCM (url \"%s\")\n",
                 settings.url.c_str());
    return 1;
  }
  mapper::Mapper m(settings.options);
  if (*store) {
    if (Status r = restoreMap(**store, settings.store_file, &m); !r) {
      std::fprintf(stderr, "evermap-mapper-proc: %s\n", r.error().message.c_str());
      return 1;
    }
  }
  mapper::LcmNode node(lcm, m, settings.node_options, *store ? &**store : nullptr);
  int status = runLoop(lcm, node, m, stop, settings.progress_s);
  node.flush();
  if (!node.storeStatus()) status = 1;
  if (!settings.quiet) std::printf("evermap-mapper-proc: %s", node.summary().c_str());
  return status;
}
