#pragma once
// The viewer's web server: the page's files over HTTP and the live stream over a WebSocket
// (subprotocol "evermap"), both by libwebsockets (Debian's libwebsockets-dev; docs/viewer.md
// says why). No HTTP is parsed here.
//
// Every client gets the Board's topics (board.h) as JSON text messages: on connecting, the
// newest of each; then each newer version when the client can take it. A text is sent in
// fragments of Options::fragment_bytes, one per writable callback, so a 10 MB map never
// makes the server queue 10 MB per client; a slow client skips versions (counted), a client
// that does not read for Options::stall_timeout_s while a text is half sent is closed, a page
// that has not acknowledged Options::max_in_flight texts gets no more until it does. The
// LCM side never waits for a client: it posts on the board and calls notify().
//
// Threading: run() is the server's loop, on its own thread; notify(), stop() and counts()
// may be called from any thread.

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "core/common/expected.h"
#include "viewer/board.h"

struct lws_context;
struct lws;

namespace evermap::viewer {

struct ServerTables;  // libwebsockets' mounts and protocols (web_server.cpp)

struct WebServerOptions {
  // Address to listen on: 127.0.0.1 by default, the page is for this machine (use 0.0.0.0 to
  // share it on a trusted network).
  std::string bind = "127.0.0.1";
  int port = 8080;  // 0: any free port (port() says which)
  // The page (index.html, viewer.js, ...) and three.js's package folder (node_modules/three).
  std::filesystem::path web_dir;
  std::filesystem::path three_dir;
  // WebSocket clients served at once; more are refused (counted).
  int max_clients = 64;
  // Bytes per WebSocket fragment.
  int fragment_bytes = 64 * 1024;
  // A client that takes no bytes for this long while a text is half sent is closed, seconds.
  int stall_timeout_s = 20;
  // Texts a client may have unacknowledged: the page acknowledges each text it has handled,
  // so a browser whose page is busy (a slow machine, a large map) holds at most this many
  // in its queue and skips to the newest when it is ready, instead of falling minutes behind
  // (a browser reads its socket eagerly: TCP alone would not slow the server down).
  int max_in_flight = 4;

  Status validate() const;
};

struct WebServerCounts {
  int64_t clients = 0;      // connected now
  int64_t connections = 0;  // accepted since start
  int64_t refused = 0;      // beyond max_clients
  int64_t texts_sent = 0;   // complete texts sent
  int64_t bytes_sent = 0;
  int64_t versions_skipped = 0;  // newer versions a slow client never got
};

class WebServer {
 public:
  // Listens at once; an error names the address (port in use, no such address).
  static Expected<std::unique_ptr<WebServer>> start(Board& board, const WebServerOptions& options);
  ~WebServer();
  WebServer(const WebServer&) = delete;
  WebServer& operator=(const WebServer&) = delete;

  // Serves until stop(). Returns at once after stop().
  void run();
  void stop();
  // The board changed: clients that are up to date are woken to take the news.
  void notify();
  // The port listened on (the one chosen by the system when Options::port is 0).
  int port() const;
  WebServerCounts counts() const;
  // counts() as JSON members for the page's "viewer" text.
  std::string countsJson() const;
  // What pages asked since the last call ("seek UTIME", "play", "pause": the --log slider),
  // oldest first; at most 16 are kept. Any thread.
  std::vector<std::string> takeCommands();

  // libwebsockets' callback (internal).
  int onEvent(lws* wsi, int reason, void* user, void* in, size_t len);

 private:
  struct Client;
  WebServer(Board& board, const WebServerOptions& options);
  // Sends the next fragment of the client's current text, or starts the next topic.
  int write(lws* wsi, Client& c);

  Board& board_;
  WebServerOptions o_;
  lws_context* context_ = nullptr;
  std::atomic<bool> stop_{false};
  std::string mount_web_, mount_three_;
  std::string bind_;
  // Counts written by the server thread, read by any.
  std::atomic<int64_t> clients_{0}, connections_{0}, refused_{0}, texts_sent_{0}, bytes_sent_{0},
      versions_skipped_{0};
  std::mutex commands_mutex_;
  std::vector<std::string> commands_;
  std::unique_ptr<ServerTables> tables_;  // stable addresses: lws keeps pointers to them
};

}  // namespace evermap::viewer
