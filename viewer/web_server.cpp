#include "viewer/web_server.h"

#include <libwebsockets.h>

#include <cstdio>
#include <cstring>
#include <new>
#include <utility>
#include <vector>

#include "viewer/json_writer.h"

namespace evermap::viewer {

struct ServerTables {
  lws_http_mount mounts[2];
  lws_protocols protocols[3];
};

// One WebSocket client: the versions it has and the text it is sending. Lives in the
// per-session memory libwebsockets allocates (constructed at ESTABLISHED, destroyed at CLOSED).
struct WebServer::Client {
  Board::Seen seen{};
  int last_topic = -1;
  Board::Text text;                   // being sent
  size_t offset = 0;                  // bytes of `text` sent
  int credit = 0;                     // texts it may still be sent before it acknowledges one
  std::vector<unsigned char> buffer;  // LWS_PRE + one fragment
};

namespace {

int callback(lws* wsi, lws_callback_reasons reason, void* user, void* in, size_t len) {
  lws_context* context = lws_get_context(wsi);
  auto* server = context ? static_cast<WebServer*>(lws_context_user(context)) : nullptr;
  if (server == nullptr) return 0;
  return server->onEvent(wsi, static_cast<int>(reason), user, in, len);
}

void logLine(int level, const char* line) {
  // libwebsockets' lines end in a newline already.
  std::fprintf(stderr, "evermap-viewer: libwebsockets: %s", line);
}

}  // namespace

Status WebServerOptions::validate() const {
  if (port < 0 || port > 65535) return makeError("port: must be in [0, 65535], got ", port);
  if (bind.empty()) return makeError("bind: an address is needed (e.g. 127.0.0.1)");
  if (max_clients < 1) return makeError("max_clients: must be >= 1, got ", max_clients);
  if (fragment_bytes < 1024)
    return makeError("fragment_bytes: must be >= 1024, got ", fragment_bytes);
  if (stall_timeout_s < 1) return makeError("stall_timeout_s: must be >= 1, got ", stall_timeout_s);
  if (max_in_flight < 1) return makeError("max_in_flight: must be >= 1, got ", max_in_flight);
  if (!std::filesystem::is_regular_file(web_dir / "index.html"))
    return makeError("web_dir: ", web_dir.string(), " holds no index.html");
  return Ok{};
}

WebServer::WebServer(Board& board, const WebServerOptions& options)
    : board_(board), o_(options), tables_(std::make_unique<ServerTables>()) {}

Expected<std::unique_ptr<WebServer>> WebServer::start(Board& board,
                                                      const WebServerOptions& options) {
  if (Status s = options.validate(); !s) return s.error();
  std::unique_ptr<WebServer> server(new WebServer(board, options));
  WebServer& w = *server;
  // libwebsockets wants mount origins without a trailing slash.
  w.mount_web_ = std::filesystem::absolute(options.web_dir).lexically_normal().string();
  w.mount_three_ = options.three_dir.empty()
                       ? std::string()
                       : std::filesystem::absolute(options.three_dir).lexically_normal().string();
  while (w.mount_web_.size() > 1 && w.mount_web_.back() == '/') w.mount_web_.pop_back();
  while (w.mount_three_.size() > 1 && w.mount_three_.back() == '/') w.mount_three_.pop_back();
  w.bind_ = options.bind;

  ServerTables& t = *w.tables_;
  std::memset(&t, 0, sizeof t);
  lws_http_mount& three = t.mounts[1];
  three.mountpoint = "/vendor/three";
  three.mountpoint_len = static_cast<unsigned char>(std::strlen(three.mountpoint));
  three.origin = w.mount_three_.c_str();
  three.origin_protocol = LWSMPRO_FILE;
  lws_http_mount& web = t.mounts[0];
  web.mount_next = w.mount_three_.empty() ? nullptr : &three;
  web.mountpoint = "/";
  web.mountpoint_len = 1;
  web.origin = w.mount_web_.c_str();
  web.def = "index.html";
  web.origin_protocol = LWSMPRO_FILE;
  // The first protocol serves HTTP (the mounts); the second is the stream.
  t.protocols[0].name = "http";
  t.protocols[0].callback = lws_callback_http_dummy;
  t.protocols[1].name = "evermap";
  t.protocols[1].callback = callback;
  t.protocols[1].per_session_data_size = sizeof(Client);
  t.protocols[1].rx_buffer_size = 1024;  // the page sends nothing that matters

  lws_set_log_level(LLL_ERR, logLine);
  lws_context_creation_info info;
  std::memset(&info, 0, sizeof info);
  info.port = options.port;
  info.iface = w.bind_.c_str();
  info.protocols = t.protocols;
  info.mounts = t.mounts;
  info.user = &w;
  info.options = LWS_SERVER_OPTION_DISABLE_IPV6;
  w.context_ = lws_create_context(&info);
  if (w.context_ == nullptr)
    return makeError("cannot listen on ", options.bind, ":", options.port,
                     " (address in use, or not an address of this machine)");
  return server;
}

WebServer::~WebServer() {
  if (context_) lws_context_destroy(context_);
}

void WebServer::run() {
  while (!stop_.load()) {
    if (lws_service(context_, 0) < 0) break;
  }
}

void WebServer::stop() {
  stop_.store(true);
  lws_cancel_service(context_);
}

void WebServer::notify() { lws_cancel_service(context_); }

int WebServer::onEvent(lws* wsi, int reason, void* user, void* in, size_t len) {
  Client* c = static_cast<Client*>(user);
  switch (reason) {
    case LWS_CALLBACK_FILTER_PROTOCOL_CONNECTION:
      if (clients_.load() >= o_.max_clients) {
        ++refused_;
        return 1;  // refuses the upgrade
      }
      return 0;
    case LWS_CALLBACK_ESTABLISHED:
      new (c) Client();
      c->buffer.resize(LWS_PRE + static_cast<size_t>(o_.fragment_bytes));
      c->credit = o_.max_in_flight;
      ++clients_;
      ++connections_;
      lws_callback_on_writable(wsi);
      return 0;
    case LWS_CALLBACK_CLOSED:
      c->~Client();
      --clients_;
      return 0;
    case LWS_CALLBACK_SERVER_WRITEABLE:
      return write(wsi, *c);
    case LWS_CALLBACK_EVENT_WAIT_CANCELLED:
      // notify(): every client that is not mid-text looks at the board.
      lws_callback_on_writable_all_protocol(context_, &tables_->protocols[1]);
      return 0;
    case LWS_CALLBACK_RECEIVE:
      // A one-byte message acknowledges one text (a page cannot earn more than max_in_flight);
      // a short one is a command for the main loop; anything else is ignored.
      if (!lws_is_first_fragment(wsi) || !lws_is_final_fragment(wsi)) return 0;
      if (len == 1) {
        if (c->credit < o_.max_in_flight) ++c->credit;
        lws_callback_on_writable(wsi);
      } else if (len > 1 && len <= 64) {
        std::lock_guard lock(commands_mutex_);
        if (commands_.size() >= 16) commands_.erase(commands_.begin());
        commands_.emplace_back(static_cast<const char*>(in), len);
      }
      return 0;
    default:
      return 0;
  }
}

int WebServer::write(lws* wsi, Client& c) {
  if (!c.text) {
    if (c.credit <= 0) return 0;  // woken again by the page's acknowledgement
    auto item = board_.next(&c.seen, c.last_topic);
    if (!item) return 0;  // up to date: woken again by notify()
    c.last_topic = static_cast<int>(item->topic);
    versions_skipped_ += static_cast<int64_t>(item->skipped);
    c.text = std::move(item->text);
    c.offset = 0;
    --c.credit;
    if (!c.text || c.text->empty()) {
      c.text.reset();
      lws_callback_on_writable(wsi);
      return 0;
    }
  }
  const std::string& text = *c.text;
  const size_t n = std::min(text.size() - c.offset, static_cast<size_t>(o_.fragment_bytes));
  const bool first = c.offset == 0;
  const bool last = c.offset + n == text.size();
  std::memcpy(c.buffer.data() + LWS_PRE, text.data() + c.offset, n);
  const int flags = lws_write_ws_flags(LWS_WRITE_TEXT, first, last);
  const int written =
      lws_write(wsi, c.buffer.data() + LWS_PRE, n, static_cast<lws_write_protocol>(flags));
  if (written < static_cast<int>(n)) return -1;  // the connection failed: close it
  bytes_sent_ += static_cast<int64_t>(n);
  c.offset += n;
  if (last) {
    c.text.reset();
    ++texts_sent_;
    lws_set_timeout(wsi, NO_PENDING_TIMEOUT, 0);
  } else {
    // Half a text is out: a client that stops reading now is closed after the stall time.
    lws_set_timeout(wsi, PENDING_TIMEOUT_USER_OK, o_.stall_timeout_s);
  }
  lws_callback_on_writable(wsi);
  return 0;
}

std::vector<std::string> WebServer::takeCommands() {
  std::lock_guard lock(commands_mutex_);
  return std::exchange(commands_, {});
}

int WebServer::port() const {
  lws_vhost* vhost = lws_get_vhost_by_name(context_, "default");
  return vhost ? lws_get_vhost_listen_port(vhost) : -1;
}

WebServerCounts WebServer::counts() const {
  WebServerCounts c;
  c.clients = clients_.load();
  c.connections = connections_.load();
  c.refused = refused_.load();
  c.texts_sent = texts_sent_.load();
  c.bytes_sent = bytes_sent_.load();
  c.versions_skipped = versions_skipped_.load();
  return c;
}

std::string WebServer::countsJson() const {
  const WebServerCounts c = counts();
  JsonWriter j;
  j.beginObject().key("clients").value(c.clients).key("connections").value(c.connections);
  j.key("refused").value(c.refused).key("texts_sent").value(c.texts_sent);
  j.key("bytes_sent")
      .value(c.bytes_sent)
      .key("versions_skipped")
      .value(c.versions_skipped)
      .endObject();
  return j.take();
}

}  // namespace evermap::viewer
