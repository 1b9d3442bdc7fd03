// evermap-mapper-run: the offline runner. Simulates a measurement-level run (a sim config as
// evermap-sim-measure reads it), maps it with the reduced pose graph, the full pose graph or
// both in one process with the registration oracle, and prints nodes, constraints, ATE and
// per-component timing. Exit status: 0 ok, 1 bad input, 2 bad command line.

#include <cstdio>
#include <cstdlib>
#include <string>

#include "core/common/key_value_file.h"
#include "mapper-proc/offline_run.h"

namespace {

constexpr const char* kUsage =
    "usage: evermap-mapper-run --config SIM.conf [--mode reduced|full|both] [--hours H]\n"
    "  --config SIM.conf  measurement-level simulation settings (config/sim-*.conf)\n"
    "  --mode M           reduced (default), full (a node per step) or both, side by side\n"
    "  --hours H          override patrol.total_hours\n"
    "  --store MAP.db     write the map store (reduced graph only), one transaction per update\n";

}  // namespace

int main(int argc, char** argv) {
  using namespace evermap;
  std::string config, mode = "reduced", store;
  double hours = -1.0;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      std::fputs(kUsage, stdout);
      return 0;
    }
    if (i + 1 >= argc) {
      std::fprintf(stderr, "evermap-mapper-run: %s needs a value\n%s", a.c_str(), kUsage);
      return 2;
    }
    const std::string v = argv[++i];
    if (a == "--config") {
      config = v;
    } else if (a == "--store") {
      store = v;
    } else if (a == "--mode" && (v == "reduced" || v == "full" || v == "both")) {
      mode = v;
    } else if (a == "--hours") {
      char* end = nullptr;
      hours = std::strtod(v.c_str(), &end);
      if (end == v.c_str() || *end || !(hours > 0)) {
        std::fprintf(stderr, "evermap-mapper-run: bad --hours %s\n", v.c_str());
        return 2;
      }
    } else {
      std::fprintf(stderr, "evermap-mapper-run: bad option %s %s\n%s", a.c_str(), v.c_str(), kUsage);
      return 2;
    }
  }
  if (config.empty()) {
    std::fprintf(stderr, "evermap-mapper-run: --config is required\n%s", kUsage);
    return 2;
  }
  auto file = KeyValueFile::load(config);
  if (!file) {
    std::fprintf(stderr, "evermap-mapper-run: %s\n", file.error().message.c_str());
    return 1;
  }
  auto sim = sim::loadSimOptions(*file);
  if (!sim) {
    std::fprintf(stderr, "evermap-mapper-run: %s\n", sim.error().message.c_str());
    return 1;
  }
  if (hours > 0) sim->patrol.total_hours = hours;
  for (const bool full : {false, true}) {
    if ((full && mode == "reduced") || (!full && mode == "full")) continue;
    mapper::MapperOptions options;
    options.full_graph = full;
    auto summary = mapper::runOffline(*sim, options, full ? std::string() : store);
    if (!summary) {
      std::fprintf(stderr, "evermap-mapper-run: %s\n", summary.error().message.c_str());
      return 1;
    }
    std::printf("== %s pose graph\n%s", full ? "full" : "reduced", summary->text().c_str());
    std::fflush(stdout);
  }
  return 0;
}
