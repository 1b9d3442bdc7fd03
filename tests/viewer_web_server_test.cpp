// viewer/web_server.h under load (issue 21, item 5): 50 clients that connect and never read, a
// MAP_GRAPH of 100,000 nodes, a flood of poses. The server must keep serving a client that
// reads (it gets the newest map and the newest pose), posting on the board must never wait
// for a client, and memory must stay bounded. Over TCP on 127.0.0.1, port chosen by the
// system (no multicast: no sandbox needed).

#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "scratch_dir.h"
#include "viewer/board.h"
#include "viewer/viewer_state.h"
#include "viewer/web_server.h"

namespace evermap::viewer {
namespace {

using Clock = std::chrono::steady_clock;

int64_t rssKb() {
  std::ifstream in("/proc/self/status");
  std::string key;
  int64_t value = 0;
  while (in >> key) {
    if (key == "VmRSS:") {
      in >> value;
      return value;
    }
    in.ignore(1 << 20, '\n');
  }
  return -1;
}

// A WebSocket client over a raw socket: the handshake, then frames (the test's own minimal
// reader; server frames are unmasked, client frames masked as RFC 6455 requires).
class RawClient {
 public:
  explicit RawClient(int port) {
    fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(static_cast<uint16_t>(port));
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    timeval tv{10, 0};
    ::setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    ok_ = ::connect(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
    const std::string request =
        "GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
        "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n"
        "Sec-WebSocket-Protocol: evermap\r\n\r\n";
    ok_ = ok_ && ::send(fd_, request.data(), request.size(), MSG_NOSIGNAL) ==
                     static_cast<ssize_t>(request.size());
  }
  ~RawClient() { ::close(fd_); }
  bool ok() const { return ok_; }

  // Reads the handshake answer; true on "101".
  bool upgraded() {
    std::string head;
    char c;
    while (head.find("\r\n\r\n") == std::string::npos && ::recv(fd_, &c, 1, 0) == 1) head += c;
    return head.rfind("HTTP/1.1 101", 0) == 0;
  }

  // A masked text frame (client to server), up to 125 bytes.
  void sendText(const std::string& text) {
    std::string frame = {
        static_cast<char>(0x81), static_cast<char>(0x80 | text.size()), 1, 2, 3, 4};
    for (size_t k = 0; k < text.size(); ++k) frame += static_cast<char>(text[k] ^ (1 + k % 4));
    ::send(fd_, frame.data(), frame.size(), MSG_NOSIGNAL);
  }

  // The next complete text message (fragments joined); acknowledges it as the page does.
  bool nextText(std::string* text) {
    text->clear();
    for (;;) {
      unsigned char h[2];
      if (!readAll(h, 2)) return false;
      const bool fin = h[0] & 0x80;
      const int opcode = h[0] & 0x0f;
      uint64_t len = h[1] & 0x7f;
      if (len == 126) {
        unsigned char b[2];
        if (!readAll(b, 2)) return false;
        len = (uint64_t{b[0]} << 8) | b[1];
      } else if (len == 127) {
        unsigned char b[8];
        if (!readAll(b, 8)) return false;
        len = 0;
        for (unsigned char x : b) len = (len << 8) | x;
      }
      std::string payload(len, '\0');
      if (len > 0 && !readAll(payload.data(), len)) return false;
      if (opcode == 1 || opcode == 0) *text += payload;
      if (fin && (opcode == 1 || opcode == 0)) {
        const unsigned char ack[] = {0x81, 0x81, 1, 2, 3, 4, 'a' ^ 1};  // masked "a"
        ::send(fd_, ack, sizeof ack, MSG_NOSIGNAL);
        return true;
      }
    }
  }

 private:
  bool readAll(void* out, size_t n) {
    auto* p = static_cast<char*>(out);
    while (n > 0) {
      const ssize_t r = ::recv(fd_, p, n, 0);
      if (r <= 0) return false;
      p += r;
      n -= static_cast<size_t>(r);
    }
    return true;
  }
  int fd_ = -1;
  bool ok_ = false;
};

map_graph_t bigGraph(int n) {
  map_graph_t g{};
  g.utime = 1;
  for (int k = 0; k < n; ++k) {
    map_node_t m{};
    m.node_id = k;
    m.position[0] = 0.1 * (k % 1000);
    m.position[1] = 0.1 * (k / 1000);
    m.position[2] = 3.0 * (k % 10);
    m.orientation[0] = 1.0;
    m.floor = k % 10;
    m.session = k % 14;
    g.nodes.push_back(m);
    if (k > 0) {
      map_edge_t e{};
      e.from_node = k - 1;
      e.to_node = k;
      e.num_measurements = 1;
      e.orientation[0] = 1.0;
      g.edges.push_back(e);
    }
  }
  g.num_nodes = static_cast<int32_t>(g.nodes.size());
  g.num_edges = static_cast<int32_t>(g.edges.size());
  return g;
}

TEST(ViewerWebServer,
     ServesTheNewestStateWhileFiftyClientsNeverReadAndAHundredThousandNodeMapIsPosted) {
  testing::ScratchDir dir;
  { std::ofstream(dir.path() / "index.html") << "<!doctype html><title>t</title>"; }
  Board board;
  ViewerState state(board);
  WebServerOptions o;
  o.port = 0;
  o.web_dir = dir.path();
  o.stall_timeout_s = 5;
  auto server = WebServer::start(board, o);
  ASSERT_TRUE(server) << server.error().message;
  std::thread serving([&] { (*server)->run(); });
  const int port = (*server)->port();
  ASSERT_GT(port, 0);
  const int64_t rss_before = rssKb();

  std::vector<std::unique_ptr<RawClient>> stuck;
  for (int k = 0; k < 50; ++k) {
    stuck.push_back(std::make_unique<RawClient>(port));
    ASSERT_TRUE(stuck.back()->ok());
  }
  const auto t0 = Clock::now();
  ASSERT_TRUE(state.onGraph(bigGraph(100000)));
  const double graph_s = std::chrono::duration<double>(Clock::now() - t0).count();
  (*server)->notify();

  RawClient reader(port);
  ASSERT_TRUE(reader.upgraded());
  // A flood of poses while the stuck clients hold the map half sent: posting never waits.
  pose_t p{};
  p.orientation[0] = 1.0;
  const auto t1 = Clock::now();
  for (int k = 1; k <= 5000; ++k) {
    p.utime = k;
    p.position[0] = k;
    ASSERT_TRUE(state.onPose(p));
    (*server)->notify();
  }
  const double poses_s = std::chrono::duration<double>(Clock::now() - t1).count();

  bool got_graph = false, got_last_pose = false;
  int poses_read = 0;
  std::string text;
  const auto deadline = Clock::now() + std::chrono::seconds(60);
  while (!(got_graph && got_last_pose) && Clock::now() < deadline && reader.nextText(&text)) {
    if (text.find("\"type\":\"graph\"") != std::string::npos)
      got_graph = text.find("\"counts\":{\"nodes\":100000,") != std::string::npos;
    if (text.find("\"type\":\"pose\"") != std::string::npos) ++poses_read;
    if (text.find("\"type\":\"pose\",\"utime\":5000,") != std::string::npos) got_last_pose = true;
  }
  EXPECT_TRUE(got_graph);
  EXPECT_TRUE(got_last_pose);
  const WebServerCounts c = (*server)->counts();
  const int64_t rss_after = rssKb();
  std::printf(
      "100000-node graph text built in %.0f ms; 5000 poses posted in %.1f ms; %lld clients, "
      "%lld texts sent, %d poses read; RSS %lld -> %lld MB\n",
      1e3 * graph_s, 1e3 * poses_s, static_cast<long long>(c.clients),
      static_cast<long long>(c.texts_sent), poses_read, static_cast<long long>(rss_before / 1024),
      static_cast<long long>(rss_after / 1024));
  EXPECT_EQ(c.clients, 51);
  EXPECT_LT(poses_read, 20);  // the reader got the newest pose, not 5000 of them
  EXPECT_LT(poses_s, 5.0);    // (0.1 s on an idle machine: no wait on any client)
  // One map text shared by every client, one fragment buffered each: far below 50 copies.
  EXPECT_LT(rss_after - rss_before, 300 * 1024);

  // A command from the page (the --log slider) reaches the main loop; acknowledgements do not.
  reader.sendText("seek 1234");
  std::vector<std::string> commands;
  for (int k = 0; k < 100 && commands.empty(); ++k) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    commands = (*server)->takeCommands();
  }
  ASSERT_EQ(commands.size(), 1u);
  EXPECT_EQ(commands[0], "seek 1234");

  (*server)->stop();
  serving.join();
}

}  // namespace
}  // namespace evermap::viewer
