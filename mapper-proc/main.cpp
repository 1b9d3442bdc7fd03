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
#include "mapper-proc/lcm_node.h"
#include "mapper-proc/map_store.h"
#include "mapper-proc/mapper.h"
#include "mapper-proc/mapper_config.h"

int main(int argc, char** argv) {
  using namespace evermap;
  // The camera mounting comes from STEREO_CALIB (LcmNode).
  mapper::MapperOptions options;
  mapper::LcmNodeOptions node_options;
  std::string url, store_file;
  bool full_graph = false, quiet = false;
  CommandLine cli(
      "evermap-mapper-proc",
      "The reduced pose graph mapper on LCM: STEREO_CALIB, VO_DELTA, WHEEL_ODOM, ATTITUDE,\n"
      "FLOOR and REGISTER_RESULT in; REGISTER_REQUEST, NODE_ADDED, POSE, MAP_GRAPH, MAPPER_STATS "
      "out.");
  cli.flag("--full-graph", &full_graph,
           "a node at every step (the paper's baseline) instead of the reduced graph");
  std::string config;
  std::vector<std::string> sets;
  cli.value("--config", &config, "MAPPER.conf",
            "the mapper's options as mapper.* settings (docs/mapper.md)");
  cli.repeated("--set", &sets, "mapper.KEY=VALUE",
               "override one mapper.* setting (after --config)");
  cli.value("--store", &store_file, "MAP.db",
            "write the map store (SQLite) after every update that changes the graph");
  cli.value("--graph-period-s", &node_options.graph_period_s, "S",
            "MAP_GRAPH after a change at most every S seconds of message time (default 1)")
      .min(0);
  cli.value("--stats-period-s", &node_options.stats_period_s, "S",
            "MAPPER_STATS every S seconds of message time (default 1)")
      .min(0);
  cli.value("--time-window-s", &node_options.input.time.window_s, "S",
            "refuse a message stamped more than S s from the stream's clock until others confirm "
            "the jump (default 120; 0: off; core/messages/inbox.h)")
      .min(0);
  cli.value("--queue", &node_options.input.queue_capacity, "N",
            "messages LCM may queue per subscription (default 10000)")
      .min(1)
      .max(1000000);
  cli.value("--lcm-url", &url, "URL", "LCM provider (default: $LCM_DEFAULT_URL)");
  cli.flag("--quiet", &quiet, "no summary on exit");
  double progress_s = 0.0;
  cli.value("--progress-s", &progress_s, "S",
            "print a progress line (message time, nodes, constraints, drops) every S s of wall "
            "time while messages arrive (0: none)")
      .min(0);
  if (const int code = cli.parseOrExit(argc, argv); code >= 0) return code;
  // SIGINT/SIGTERM blocked, then polled between LCM waits: before any thread starts (restoring
  // a stored map runs a solver batch, whose background worker would otherwise take the signal
  // and die of it, with no summary and no last flush).
  StopSignals stop;
  options.full_graph = full_graph;
  auto settings = config.empty() ? KeyValueFile::parse("", "--set") : KeyValueFile::load(config);
  if (settings) {
    if (Status s = settings->setAll(sets, "--set"); !s) settings = s.error();
  }
  if (!settings) {
    std::fprintf(stderr, "evermap-mapper-proc: %s\n", settings.error().message.c_str());
    return 2;
  }
  if (Status s = mapper::readMapperOptions(*settings, &options); !s) {
    std::fprintf(stderr, "evermap-mapper-proc: %s\n", s.error().message.c_str());
    return 2;
  }
  for (Status s : {options.validate(), node_options.validate()}) {
    if (!s) {
      std::fprintf(stderr, "evermap-mapper-proc: %s\n", s.error().message.c_str());
      return 2;
    }
  }

  std::optional<mapper::MapStore> store;
  if (!store_file.empty()) {
    auto opened = mapper::MapStore::open(store_file);
    if (!opened) {
      std::fprintf(stderr, "evermap-mapper-proc: %s\n", opened.error().message.c_str());
      return 1;
    }
    store = std::move(*opened);
  }

  lcm::LCM lcm(url);
  if (!lcm.good()) {
    std::fprintf(stderr, "evermap-mapper-proc: cannot start LCM (url \"%s\")\n", url.c_str());
    return 1;
  }
  mapper::Mapper m(options);
  // A store that holds a map (a restart after a crash, or a new session over a saved map):
  // the mapper continues it, lost until a global registration places it on the map.
  if (store) {
    auto held = store->load();
    if (!held) {
      std::fprintf(stderr, "evermap-mapper-proc: %s\n", held.error().message.c_str());
      return 1;
    }
    if (!held->nodes.empty()) {
      if (Status r = m.restore(*held); !r) {
        std::fprintf(stderr, "evermap-mapper-proc: %s: %s\n", store_file.c_str(),
                     r.error().message.c_str());
        return 1;
      }
      std::printf("evermap-mapper-proc: continuing %s: %zu nodes, %zu constraints restored\n",
                  store_file.c_str(), m.nodes().size(), m.constraints().all().size());
      std::fflush(stdout);
    }
  }
  mapper::LcmNode node(lcm, m, node_options, store ? &*store : nullptr);
  int status = 0;
  // Progress is for the person watching, so it runs on the wall clock; the map never sees it.
  using Clock = std::chrono::steady_clock;
  const auto started = Clock::now();
  auto next_progress = started;
  // Data time mapped so far; a jump of an hour or more (the gap between
  // sessions) is not counted.
  int64_t previous_utime = -1;
  double data_s = 0.0;
  while (!stop.requested()) {
    const int handled = lcm.handleTimeout(200);
    if (handled < 0) {
      std::fprintf(stderr, "evermap-mapper-proc: LCM failed\n");
      status = 1;
      break;
    }
    // Idle: whatever changed since the last MAP_GRAPH goes out now (the end of a replay).
    if (handled == 0) node.flush();
    if (progress_s > 0.0 && node.lastUtime() >= 0 && Clock::now() >= next_progress) {
      const int64_t now_utime = node.lastUtime();
      if (previous_utime >= 0 && now_utime > previous_utime) {
        const double step_s = 1e-6 * static_cast<double>(now_utime - previous_utime);
        if (step_s < 3600.0) data_s += step_s;
      }
      previous_utime = now_utime;
      next_progress = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                         std::chrono::duration<double>(progress_s));
      std::printf(
          "progress: wall %.0f s, data %.0f s, session %d, nodes %zu, "
          "constraints %zu, dropped %lld\n",
          std::chrono::duration<double>(Clock::now() - started).count(), data_s, m.session(),
          m.nodes().size(), m.constraints().all().size(),
          static_cast<long long>(node.counts().dropped()));
      std::fflush(stdout);
    }
  }
  node.flush();
  if (!node.storeStatus()) status = 1;
  if (!quiet) std::printf("evermap-mapper-proc: %s", node.summary().c_str());
  return status;
}
