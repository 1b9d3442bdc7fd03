// evermap-viewer: watch the map being built, in a browser (issue 21, docs/viewer.md). Parses
// options, finds the page's files, starts the web server on its thread and runs the LCM loop
// (LcmListener); or, with --store, shows a stored map without LCM.
// Exit status: 0 on SIGINT/SIGTERM, 1 LCM, store or listening failure, 2 bad command line.

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <algorithm>
#include <filesystem>
#include <optional>
#include <set>
#include <string>
#include <system_error>
#include <thread>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "core/messages/channels.h"

#include "core/common/command_line.h"
#include "core/common/stop_signals.h"
#include "core/messages/key_option.h"
#include "viewer/board.h"
#include "viewer/json_writer.h"
#include "viewer/lcm_listener.h"
#include "viewer/log_player.h"
#include "viewer/plan_folder.h"
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
  if (const char* env = std::getenv("EVERMAP_VIEWER_WEB"); env && *env)
    candidates.emplace_back(env);
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) candidates.push_back(exe.parent_path() / ".." / "share" / "evermap" / "viewer" / "web");
  candidates.emplace_back(EVERMAP_VIEWER_SOURCE_WEB_DIR);
  for (const fs::path& p : candidates)
    if (fs::is_regular_file(p / "index.html", ec)) return p;
  return candidates.back();
}

// The --log loop: plays the log at `speed` from its start, follows the page's commands
// ("seek UTIME", "play", "pause", "speed X"); a seek back starts the viewer's state afresh.
int playLog(evermap::viewer::LogPlayer& player, lcm::LCM& lcm,
            std::optional<evermap::viewer::LcmListener>& listener,
            const evermap::viewer::LcmListenerOptions& listen, evermap::viewer::Board& board,
            evermap::viewer::WebServer& server, evermap::StopSignals& stop, const std::string& file,
            double speed) {
  using namespace evermap;
  using Clock = std::chrono::steady_clock;
  auto send = [&lcm](const std::string& channel, const void* data, size_t size) {
    lcm.publish(channel, data, static_cast<unsigned>(size));
    while (lcm.handleTimeout(0) > 0) {
    }
  };
  int64_t t = player.startUtime();
  bool playing = true;
  auto last = Clock::now();
  auto next_counts = last;
  std::string last_text;
  while (!stop.requested()) {
    for (const std::string& text : server.takeCommands()) {
      const std::optional<viewer::LogCommand> command = viewer::parseLogCommand(text);
      if (!command) continue;  // not a command: ignored
      switch (command->kind) {
        case viewer::LogCommand::Kind::kPlay:
          playing = true;
          if (t >= player.endUtime()) {  // play again from the start
            listener.reset();
            listener.emplace(lcm, board, listen);
            player.rewind();
            t = player.startUtime();
          }
          break;
        case viewer::LogCommand::Kind::kPause:
          playing = false;
          break;
        case viewer::LogCommand::Kind::kSeek:
          t = std::clamp<int64_t>(command->utime, player.startUtime(), player.endUtime());
          if (t < player.position()) {
            listener.reset();
            listener.emplace(lcm, board, listen);
            player.rewind();
          }
          break;
        case viewer::LogCommand::Kind::kSpeed:
          speed = command->speed;
          break;
      }
    }
    const auto now = Clock::now();
    if (playing)
      t += static_cast<int64_t>(speed * 1e6 * std::chrono::duration<double>(now - last).count());
    last = now;
    if (t >= player.endUtime()) {
      t = player.endUtime();
      playing = false;
    }
    player.playTo(t, send);
    viewer::JsonWriter j;
    j.beginObject().key("type").value("log").key("file").value(file);
    j.key("start").value(player.startUtime()).key("end").value(player.endUtime());
    j.key("t").value(t).key("playing").value(playing).key("speed").value(speed, 2).endObject();
    std::string text = j.take();
    if (text != last_text) {
      board.post(viewer::Topic::kLog, text);
      last_text = std::move(text);
    }
    if (now >= next_counts) {
      listener->postCounts(server.countsJson());
      next_counts = now + std::chrono::seconds(1);
    }
    server.notify();
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return 0;
}

// What the viewer runs with: the web server's and the listener's settings that a user
// chooses, declared once (--help, --config, --set, --print-config); the flags below set the
// same fields.
struct Settings {
  evermap::viewer::WebServerOptions web;
  evermap::viewer::LcmListenerOptions listen;
  std::string url, store_file, log_file, web_dir, key_file, plans_dir;
  double log_speed = 1.0;
  double plans_period_s = 2.0;
  bool quiet = false;

  void declareOptions(evermap::OptionList& o) {
    o.add("bind", &web.bind, "", "address to listen on (127.0.0.1: this machine only)");
    o.add("port", &web.port, "", "TCP port; 0: any free port, printed").in(0, 65535);
    o.add("max_clients", &web.max_clients, "", "browser connections served at once").min(1);
    o.add("image_period_s", &listen.image_period_s, "s",
          "wall seconds between two camera images sent")
        .nonNegative();
    o.add("image_width", &listen.image_width, "px", "width of the camera images sent").in(16, 4096);
    o.add("log_speed", &log_speed, "x", "--log: playing speed, x real time")
        .in(evermap::viewer::kMinLogSpeed, evermap::viewer::kMaxLogSpeed);
    o.add("plans_period_s", &plans_period_s, "s",
          "--plans: how often the folder is looked at for a new export")
        .in(0.1, 3600.0);
  }
};

// The page's files and three.js (without it the page has no 3-D view).
void findPage(const std::string& web_dir, evermap::viewer::WebServerOptions* web) {
  web->web_dir = findWebDir(web_dir);
  web->three_dir = web->web_dir / "node_modules" / "three";
  if (!fs::is_regular_file(web->three_dir / "build" / "three.module.js")) {
    std::fprintf(stderr,
                 "evermap-viewer: three.js is not installed in %s (run scripts/setup.sh): "
                 "the page has no 3-D view\n",
                 web->three_dir.c_str());
    web->three_dir.clear();
  }
}

// The command line; -1 to run, else the exit status.
int parse(int argc, char** argv, Settings* s) {
  using namespace evermap;
  CommandLine cli(
      "evermap-viewer",
      "Serves a page that shows the map as it is built: MAP_GRAPH, POSE, FLOOR, MAPPER_STATS,\n"
      "REGISTER_RESULT, DEPUTY_STATUS, VO_DELTA, KEYFRAME and STEREO in (read-only: it\n"
      "publishes nothing), HTTP and a WebSocket stream out. Open http://BIND:PORT/.");
  cli.value("--bind", &s->web.bind, "ADDR",
            "address to listen on (default 127.0.0.1: this machine only)");
  cli.value("--port", &s->web.port, "N", "TCP port (default 8080; 0: any free port, printed)")
      .min(0)
      .max(65535);
  cli.value("--store", &s->store_file, "MAP.db",
            "show this map store (SQLite) instead of listening to LCM");
  cli.value("--log", &s->log_file, "FILE.lcmlog",
            "play this LCM log instead of listening to LCM, with a time slider on the page");
  cli.value("--speed", &s->log_speed, "X",
            "--log: playing speed, x real time (default 1; 0.01-1000, also set on the page)")
      .min(viewer::kMinLogSpeed)
      .max(viewer::kMaxLogSpeed);
  cli.value("--plans", &s->plans_dir, "DIR",
            "show the current floor's plan from this evermap-map-export folder under the map "
            "(a new export is picked up)");
  cli.value("--web-dir", &s->web_dir, "DIR",
            "the page's files (default: found next to the program or in the source tree)");
  cli.value("--max-clients", &s->web.max_clients, "N",
            "browser connections served at once (default 64)")
      .min(1);
  cli.value("--image-period-s", &s->listen.image_period_s, "S",
            "wall seconds between two camera images sent (default 0.5)")
      .min(0);
  cli.value("--lcm-url", &s->url, "URL", "LCM provider (default: $LCM_DEFAULT_URL)");
  cli.flag("--quiet", &s->quiet, "no summary on exit");
  messages::declareKeyOption(cli, &s->key_file);
  cli.options(s, "viewer.");
  cli.check([s]() -> Status {
    findPage(s->web_dir, &s->web);
    if (!s->store_file.empty() && !s->log_file.empty())
      return makeError("--store and --log: one or the other");
    if (!s->plans_dir.empty() && !std::filesystem::is_directory(s->plans_dir))
      return makeError("--plans ", s->plans_dir, ": not a folder");
    if (Status v = s->web.validate(); !v) return v;
    return s->listen.validate();
  });
  return cli.parseOrExit(argc, argv);
}

// Offline: the stored map, once; the server shows it until stopped. 0, or 1 on a bad store.
int showStore(const std::string& store_file, const Settings& s, evermap::viewer::Board& board,
              evermap::viewer::WebServer& server, evermap::StopSignals& stop) {
  using namespace evermap;
  auto stored = viewer::loadStoredGraph(store_file);
  if (!stored) {
    std::fprintf(stderr, "evermap-viewer: %s\n", stored.error().message.c_str());
    return 1;
  }
  viewer::ViewerState state(board, s.listen.state);
  if (Status r = state.onGraph(stored->graph, store_file); !r) {
    std::fprintf(stderr, "evermap-viewer: %s: %s\n", store_file.c_str(), r.error().message.c_str());
    return 1;
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
  std::printf(
      "evermap-viewer: %s: %lld nodes, %lld edges (%lld loop closures), %lld floors, "
      "%lld sessions, %lld rejected constraints\n",
      store_file.c_str(), static_cast<long long>(g.nodes), static_cast<long long>(g.edges),
      static_cast<long long>(g.closures), static_cast<long long>(g.floors),
      static_cast<long long>(g.sessions), static_cast<long long>(stored->rejected));
  std::fflush(stdout);
  server.notify();
  while (!stop.requested()) std::this_thread::sleep_for(std::chrono::milliseconds(200));
  return 0;
}

// --log: the log to play into an in-process LCM, read by the same listener.
evermap::Expected<evermap::viewer::LogPlayer> openLog(const std::string& log_file) {
  using namespace evermap;
  const std::set<std::string> channels_shown = {
      channels::kMapGraph,    channels::kPose,           channels::kFloor,
      channels::kMapperStats, channels::kRegisterResult, channels::kDeputyStatus,
      channels::kVoDelta,     channels::kStereo,         channels::kKeyframe};
  auto player = viewer::LogPlayer::open(log_file, channels_shown);
  if (!player) return player.error();
  std::printf("evermap-viewer: %s: %zu events over %.1f s (%lld camera images, one per %.1f s)\n",
              log_file.c_str(), player->events(),
              1e-6 * static_cast<double>(player->endUtime() - player->startUtime()),
              static_cast<long long>(player->images()),
              1e-6 * static_cast<double>(player->imagePeriodUs()));
  std::fflush(stdout);
  return player;
}

// Live: LCM until SIGINT/SIGTERM; 0, or 1 when LCM fails.
int listenLive(lcm::LCM& lcm, evermap::viewer::LcmListener& listener,
               evermap::viewer::WebServer& server, evermap::StopSignals& stop) {
  using Clock = std::chrono::steady_clock;
  auto next_counts = Clock::now();
  while (!stop.requested()) {
    // Short waits: the clients are woken at most every 20 ms however fast messages come.
    if (lcm.handleTimeout(20) < 0) {
      std::fprintf(stderr, "evermap-viewer: LCM failed\n");
      return 1;
    }
    if (Clock::now() >= next_counts) {
      listener.postCounts(server.countsJson());
      next_counts = Clock::now() + std::chrono::seconds(1);
    }
    server.notify();
  }
  return 0;
}

void printSummary(const evermap::viewer::LcmListener& listener,
                  const evermap::viewer::WebServerCounts& c) {
  std::printf(
      "evermap-viewer: %s\ngraphs %lld\nlast_graph_nodes %lld\nimages_sent %lld\n"
      "connections %lld\nrefused_connections %lld\ntexts_sent %lld\nversions_skipped %lld\n",
      listener.inbox().summary().c_str(), static_cast<long long>(listener.state().graphs()),
      static_cast<long long>(listener.state().lastGraph().nodes),
      static_cast<long long>(listener.imagesSent()), static_cast<long long>(c.connections),
      static_cast<long long>(c.refused), static_cast<long long>(c.texts_sent),
      static_cast<long long>(c.versions_skipped));
}

}  // namespace

int main(int argc, char** argv) {
  using namespace evermap;
  Settings s;
  if (const int code = parse(argc, argv, &s); code >= 0) return code;
  // Signals blocked before any thread starts, then polled (the server thread inherits it).
  StopSignals stop;
  viewer::Board board;
  auto server = viewer::WebServer::start(board, s.web);
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
  std::printf("evermap-viewer: serving http://%s:%d/ (page from %s)\n", s.web.bind.c_str(),
              (*server)->port(), s.web.web_dir.c_str());
  std::fflush(stdout);
  std::optional<viewer::PlanWatcher> plans;
  if (!s.plans_dir.empty()) plans.emplace(s.plans_dir, board, **server, s.plans_period_s);
  if (!s.store_file.empty()) return finish(showStore(s.store_file, s, board, **server, stop));

  std::optional<viewer::LogPlayer> player;
  if (!s.log_file.empty()) {
    auto opened = openLog(s.log_file);
    if (!opened) {
      std::fprintf(stderr, "evermap-viewer: %s\n", opened.error().message.c_str());
      return finish(1);
    }
    player = std::move(*opened);
    s.url = "memq://";
  }
  lcm::LCM lcm(s.url);
  if (!lcm.good()) {
    std::fprintf(stderr, "evermap-viewer: cannot start LCM (url \"%s\")\n", s.url.c_str());
    return finish(1);
  }
  if (!player) {  // a --log plays into memq: no key there
    auto signer = messages::makeSigner("evermap-viewer", s.key_file);
    if (!signer) {
      std::fprintf(stderr, "evermap-viewer: %s\n", signer.error().message.c_str());
      return finish(2);
    }
    s.listen.input.signer = *signer;
  }
  std::optional<viewer::LcmListener> listener;
  listener.emplace(lcm, board, s.listen);
  if (player) {
    return finish(
        playLog(*player, lcm, listener, s.listen, board, **server, stop, s.log_file, s.log_speed));
  }
  const int status = finish(listenLive(lcm, *listener, **server, stop));
  if (!s.quiet) printSummary(*listener, (*server)->counts());
  return status;
}
