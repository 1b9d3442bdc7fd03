// evermap-viewer-graph-pub: publishes one map, again and again, on MAP_GRAPH at a fixed rate,
// for bench/viewer_latency.sh (issue 21: latency from MAP_GRAPH to the page's pixels). Each
// message carries its publish time, wall clock in microseconds, as `utime`, so the page (same
// machine, same clock) can tell how long the map took from LCM to a drawn frame. Run it inside
// scripts/lcm-sandbox only (it publishes on LCM_DEFAULT_URL).
//
// The map is either
//   --store MAP.db   a map store (the reduced graph the mapper keeps: ~3,000 nodes at paper
//                    scale, `evermap-mapper-run --config config/sim-paper-scale.conf --store`), or
//   --steps FILE.csv the step poses of a run (`evermap-mapper-run --out DIR`: steps-reduced.csv)
//                    as the full graph would hold them: a node per step (~56,000 at paper scale,
//                    docs/mapper.md: the full graph has 55,897), odometry edges between a
//                    session's consecutive steps, and a loop edge from each step that comes back
//                    to a place (the reduced node it hangs on) to that place's first step, at
//                    most --max-loops of them (the full paper-scale graph had 30,193 closures).
#include <chrono>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <unordered_map>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include <evermap/map_graph_t.hpp>

#include "core/common/command_line.h"
#include "core/common/option_fields.h"
#include "core/messages/channels.h"
#include "viewer/store_graph.h"

namespace {

using namespace evermap;

int64_t wallUs() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

map_edge_t edge(int64_t a, int64_t b, int8_t type) {
  map_edge_t e{};
  e.from_node = a;
  e.to_node = b;
  e.type = type;
  e.num_measurements = 1;
  e.orientation[0] = 1.0;
  return e;
}

// The columns of steps-<mode>.csv that matter here (tools/mapper-run).
bool graphFromSteps(const std::string& file, int max_loops, map_graph_t* g, std::string* error) {
  std::ifstream in(file);
  if (!in) {
    *error = file + ": cannot open";
    return false;
  }
  std::string line;
  std::getline(in, line);
  std::map<std::string, int> col;
  {
    std::stringstream s(line);
    std::string name;
    for (int k = 0; std::getline(s, name, ','); ++k) col[name] = k;
  }
  for (const char* need : {"utime", "session", "node", "true_floor", "est_x", "est_y", "est_z"})
    if (!col.count(need)) {
      *error = file + ": no column " + need + " (not a steps CSV)";
      return false;
    }
  std::unordered_map<int64_t, int64_t> first_step_of_place;  // reduced node -> first step there
  std::map<int, std::pair<double, int>> floor_z;             // floor -> (sum of z, count)
  int loops = 0;
  std::vector<std::string> f;
  while (std::getline(in, line)) {
    f.clear();
    std::stringstream s(line);
    for (std::string v; std::getline(s, v, ',');) f.push_back(v);
    if (f.size() < col.size()) continue;
    map_node_t n{};
    n.node_id = static_cast<int64_t>(g->nodes.size());
    n.keyframe_utime = std::stoll(f[col["utime"]]);
    n.position[0] = std::stod(f[col["est_x"]]);
    n.position[1] = std::stod(f[col["est_y"]]);
    n.position[2] = std::stod(f[col["est_z"]]);
    n.orientation[0] = 1.0;
    n.floor = std::stoi(f[col["true_floor"]]);
    n.session = std::stoi(f[col["session"]]);
    if (!g->nodes.empty() && g->nodes.back().session == n.session)
      g->edges.push_back(edge(n.node_id - 1, n.node_id, map_edge_t::TYPE_ODOMETRY));
    const int64_t place = std::stoll(f[col["node"]]);
    auto [it, first] = first_step_of_place.try_emplace(place, n.node_id);
    // A step back at a place seen more than 30 steps earlier: the full graph's loop closure.
    if (!first && n.node_id - it->second > 30 && loops < max_loops) {
      g->edges.push_back(edge(it->second, n.node_id, map_edge_t::TYPE_LOOP));
      ++loops;
    }
    auto& z = floor_z[n.floor];
    z.first += n.position[2];
    ++z.second;
    g->nodes.push_back(n);
  }
  for (const auto& [index, z] : floor_z)
    g->floors.push_back(map_floor_t{index, z.first / z.second});
  g->num_nodes = static_cast<int32_t>(g->nodes.size());
  g->num_edges = static_cast<int32_t>(g->edges.size());
  g->num_floors = static_cast<int32_t>(g->floors.size());
  return true;
}

// The publisher's settings (--help lists them, --print-config prints them).
struct GraphPubOptions {
  double rate_hz = 1.0, duration_s = 30.0;
  int max_loops = 30193;
  void declareOptions(OptionList& o) {
    o.add("max_loops", &max_loops, "", "most loop edges of the --steps graph").min(0);
    o.add("rate_hz", &rate_hz, "Hz", "messages per second").positive().max(1000);
    o.add("duration_s", &duration_s, "s", "how long to publish").min(0);
  }
};

}  // namespace

int main(int argc, char** argv) {
  CommandLine cli(
      "evermap-viewer-graph-pub",
      "Publishes one map on MAP_GRAPH at a fixed rate, utime = publish time (wall clock, us); "
      "for bench/viewer_latency.sh, inside scripts/lcm-sandbox.");
  std::string store, steps;
  GraphPubOptions options;
  const double &rate_hz = options.rate_hz, &duration_s = options.duration_s;
  const int& max_loops = options.max_loops;
  bool describe = false;
  cli.value("--store", &store, "MAP.db", "publish the map of this store (reduced graph)");
  cli.value("--steps", &steps, "FILE.csv",
            "publish a full graph made of a run's step poses (steps-*.csv)");
  cli.options(&options);
  cli.alias("--max-loops", "max_loops", "N");
  cli.alias("--rate-hz", "rate_hz", "HZ");
  cli.alias("--duration-s", "duration_s", "S");
  cli.flag("--describe", &describe, "print the map's counts and encoded size, publish nothing");
  if (const int code = cli.parseOrExit(argc, argv); code >= 0) return code;
  if (store.empty() == steps.empty()) {
    std::fprintf(stderr, "evermap-viewer-graph-pub: give one of --store, --steps\n%s",
                 cli.usage().c_str());
    return 2;
  }
  map_graph_t g;
  if (!store.empty()) {
    auto stored = viewer::loadStoredGraph(store);
    if (!stored) {
      std::fprintf(stderr, "evermap-viewer-graph-pub: %s\n", stored.error().message.c_str());
      return 1;
    }
    g = std::move(stored->graph);
  } else if (std::string error; !graphFromSteps(steps, max_loops, &g, &error)) {
    std::fprintf(stderr, "evermap-viewer-graph-pub: %s\n", error.c_str());
    return 1;
  }
  int loops = 0;
  for (const map_edge_t& e : g.edges) loops += e.type == map_edge_t::TYPE_LOOP;
  std::vector<uint8_t> bytes(static_cast<size_t>(g.getEncodedSize()));
  std::printf("graph nodes %d edges %d loops %d floors %d bytes %zu\n", g.num_nodes, g.num_edges,
              loops, g.num_floors, bytes.size());
  std::fflush(stdout);
  if (describe) return 0;

  lcm::LCM lcm;
  if (!lcm.good()) {
    std::fprintf(stderr, "evermap-viewer-graph-pub: LCM is not available\n");
    return 1;
  }
  const auto period = std::chrono::duration<double>(1.0 / rate_hz);
  const auto start = std::chrono::steady_clock::now();
  long sent = 0;
  double encode_ms = 0.0;
  for (auto next = start;
       std::chrono::steady_clock::now() - start < std::chrono::duration<double>(duration_s);
       next += std::chrono::duration_cast<std::chrono::steady_clock::duration>(period)) {
    std::this_thread::sleep_until(next);
    const auto t0 = std::chrono::steady_clock::now();
    g.utime = wallUs();
    g.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
    encode_ms +=
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    if (lcm.publish(channels::kMapGraph, bytes.data(), static_cast<unsigned>(bytes.size())) != 0)
      std::fprintf(stderr, "evermap-viewer-graph-pub: publish failed\n");
    ++sent;
  }
  std::printf("published %ld encode_ms_mean %.1f\n", sent, sent > 0 ? encode_ms / sent : 0.0);
  return 0;
}
