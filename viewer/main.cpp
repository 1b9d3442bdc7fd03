// evermap-viewer: watch the map being built, in a browser (issue 21, docs/viewer.md). Parses
// options, finds the page's files, starts the web server on its thread and runs the LCM loop
// (LcmListener); or, with --store, shows a stored map without LCM.
// Exit status: 0 on SIGINT/SIGTERM, 1 LCM, store or listening failure, 2 bad command line.

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <system_error>
#include <thread>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "core/common/command_line.h"
#include "core/common/stop_signals.h"
#include "viewer/board.h"
#include "viewer/lcm_listener.h"
#include "viewer/store_graph.h"
#include "viewer/viewer_state.h"
#include "viewer/web_server.h"

namespace {

namespace fs = std::filesystem;

// The page's folder: --web-dir, else $EVERMAP_VIEWER_WEB, else next to the program
// (../share/evermap/viewer/web for an installed tree), else the source tree it was built from.
fs::path findWebDir(const std::string& given) {
  std::vector<fs::path> candidates;
  if (!given.empty()) return given;
  if (const char* env = std::getenv("EVERMAP_VIEWER_WEB"); env && *env) candidates.emplace_back(env);
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) candidates.push_back(exe.parent_path() / ".." / "share" / "evermap" / "viewer" / "web");
  candidates.emplace_back(EVERMAP_VIEWER_SOURCE_WEB_DIR);
  for (const fs::path& p : candidates)
    if (fs::is_regular_file(p / "index.html", ec)) return p;
  return candidates.back();
}

}  // namespace

int main(int argc, char** argv) {
  using namespace evermap;
  viewer::WebServerOptions web;
  viewer::LcmListenerOptions listen;
  std::string url, store_file, web_dir;
  bool quiet = false;
  CommandLine cli("evermap-viewer",
                  "Serves a page that shows the map as it is built: MAP_GRAPH, POSE, FLOOR, MAPPER_STATS,\n"
                  "REGISTER_RESULT, DEPUTY_STATUS, VO_DELTA, KEYFRAME and STEREO in (read-only: it\n"
                  "publishes nothing), HTTP and a WebSocket stream out. Open http://BIND:PORT/.");
  cli.value("--bind", &web.bind, "ADDR", "address to listen on (default 127.0.0.1: this machine only)");
  cli.value("--port", &web.port, "N", "TCP port (default 8080; 0: any free port, printed)");
  cli.value("--store", &store_file, "MAP.db", "show this map store (SQLite) instead of listening to LCM");
  cli.value("--web-dir", &web_dir, "DIR", "the page's files (default: found next to the program or in the source tree)");
  cli.value("--max-clients", &web.max_clients, "N", "browser connections served at once (default 64)");
  cli.value("--image-period-s", &listen.image_period_s, "S", "wall seconds between two camera images sent (default 0.5)");
  cli.value("--lcm-url", &url, "URL", "LCM provider (default: $LCM_DEFAULT_URL)");
  cli.flag("--quiet", &quiet, "no summary on exit");
  if (const int code = cli.parseOrExit(argc, argv); code >= 0) return code;
  // Signals blocked before any thread starts, then polled (the server thread inherits it).
  StopSignals stop;

  web.web_dir = findWebDir(web_dir);
  web.three_dir = web.web_dir / "node_modules" / "three";
  if (!fs::is_regular_file(web.three_dir / "build" / "three.module.js")) {
    std::fprintf(stderr, "evermap-viewer: three.js is not installed in %s (run scripts/setup.sh): "
                 "the page has no 3-D view\n", web.three_dir.c_str());
    web.three_dir.clear();
  }
  for (Status s : {web.validate(), listen.validate()}) {
    if (!s) {
      std::fprintf(stderr, "evermap-viewer: %s\n", s.error().message.c_str());
      return 2;
    }
  }

  viewer::Board board;
  auto server = viewer::WebServer::start(board, web);
  if (!server) {
    std::fprintf(stderr, "evermap-viewer: %s\n", server.error().message.c_str());
    return 1;
  }
  std::thread serving([&] { (*server)->run(); });
  auto finish = [&](int status) {
    (*server)->stop();
    serving.join();
    return status;
  };

  std::printf("evermap-viewer: serving http://%s:%d/ (page from %s)\n", web.bind.c_str(), (*server)->port(),
              web.web_dir.c_str());
  std::fflush(stdout);

  if (!store_file.empty()) {
    // Offline: the stored map, once; the server shows it until stopped.
    auto stored = viewer::loadStoredGraph(store_file);
    if (!stored) {
      std::fprintf(stderr, "evermap-viewer: %s\n", stored.error().message.c_str());
      return finish(1);
    }
    viewer::ViewerState state(board, listen.state);
    if (Status s = state.onGraph(stored->graph, store_file); !s) {
      std::fprintf(stderr, "evermap-viewer: %s: %s\n", store_file.c_str(), s.error().message.c_str());
      return finish(1);
    }
    const viewer::GraphSummary& g = state.lastGraph();
    // The counts the mapper would publish for this map (MAPPER_STATS), for the page's table.
    mapper_stats_t stats{};
    stats.utime = stored->graph.utime;
    stats.num_nodes = static_cast<int32_t>(g.nodes);
    stats.num_edges = static_cast<int32_t>(g.edges);
    stats.num_floors = static_cast<int32_t>(g.floors);
    stats.num_sessions = static_cast<int32_t>(g.sessions);
    stats.num_rejected = stored->rejected;
    (void)state.onStats(stats);
    std::printf("evermap-viewer: %s: %lld nodes, %lld edges (%lld loop closures), %lld floors, "
                "%lld sessions, %lld rejected constraints\n",
                store_file.c_str(), static_cast<long long>(g.nodes), static_cast<long long>(g.edges),
                static_cast<long long>(g.closures), static_cast<long long>(g.floors),
                static_cast<long long>(g.sessions), static_cast<long long>(stored->rejected));
    std::fflush(stdout);
    (*server)->notify();
    while (!stop.requested()) std::this_thread::sleep_for(std::chrono::milliseconds(200));
    return finish(0);
  }

  lcm::LCM lcm(url);
  if (!lcm.good()) {
    std::fprintf(stderr, "evermap-viewer: cannot start LCM (url \"%s\")\n", url.c_str());
    return finish(1);
  }
  viewer::LcmListener listener(lcm, board, listen);
  int status = 0;
  using Clock = std::chrono::steady_clock;
  auto next_counts = Clock::now();
  while (!stop.requested()) {
    // Short waits: the clients are woken at most every 20 ms however fast messages come.
    const int handled = lcm.handleTimeout(20);
    if (handled < 0) {
      std::fprintf(stderr, "evermap-viewer: LCM failed\n");
      status = 1;
      break;
    }
    if (Clock::now() >= next_counts) {
      listener.postCounts((*server)->countsJson());
      next_counts = Clock::now() + std::chrono::seconds(1);
    }
    (*server)->notify();
  }
  status = finish(status);
  if (!quiet) {
    const viewer::WebServerCounts c = (*server)->counts();
    std::printf("evermap-viewer: %s\ngraphs %lld\nlast_graph_nodes %lld\nimages_sent %lld\n"
                "connections %lld\nrefused_connections %lld\ntexts_sent %lld\nversions_skipped %lld\n",
                listener.inbox().summary().c_str(), static_cast<long long>(listener.state().graphs()),
                static_cast<long long>(listener.state().lastGraph().nodes),
                static_cast<long long>(listener.imagesSent()), static_cast<long long>(c.connections),
                static_cast<long long>(c.refused), static_cast<long long>(c.texts_sent),
                static_cast<long long>(c.versions_skipped));
  }
  return status;
}
