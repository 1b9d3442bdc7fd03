// evermap-lcm-link: the only link between two network namespaces ("robot" and "base"), for
// LCM (docs/deployment.md). In each namespace it joins the LCM multicast group and forwards
// every datagram it hears to the other namespace's group, as it is (LCM's fragments are not
// reassembled), with the faults of LinkOptions: seeded loss, delay with jitter, a partition
// window. It stands in for `tc netem` where the kernel has no sch_netem. On SIGINT or SIGTERM
// it prints, per direction and channel, what it forwarded and dropped, and exits 0.
//
//   evermap-lcm-link --ns-a /proc/PID_A/ns/net --ns-b /proc/PID_B/ns/net \
//       [--name-a robot] [--name-b base] [--set loss_pct=5] ...
#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <sched.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <deque>
#include <string>
#include <vector>

#include "core/common/command_line.h"
#include "tools/lcm-link/link.h"

namespace {

using namespace evermap;

volatile std::sig_atomic_t g_stop = 0;
void onSignal(int) { g_stop = 1; }

struct Settings {
  std::string ns[2], name[2] = {"robot", "base"};
  std::string group = "239.255.76.67";
  int64_t port = 7667;
  link::LinkOptions link;
};

// One namespace's end: a socket that hears the group and one that speaks into it (its port
// tells our own datagrams apart when they come back over the loopback).
struct End {
  int hear = -1, speak = -1;
  uint16_t speak_port = 0;
  sockaddr_in group{};
};

struct Pending {
  double leave_s;
  std::vector<uint8_t> bytes;
};

bool fail(const std::string& what) {
  std::fprintf(stderr, "evermap-lcm-link: %s: %s\n", what.c_str(), std::strerror(errno));
  return false;
}

// The two sockets of one end, made inside the namespace of `ns_path` (they stay in it).
bool openEnd(const Settings& s, const std::string& ns_path, End* end) {
  const int ns = open(ns_path.c_str(), O_RDONLY | O_CLOEXEC);
  if (ns < 0) return fail("--ns " + ns_path);
  if (setns(ns, CLONE_NEWNET) != 0) return fail("setns " + ns_path);
  close(ns);
  end->group.sin_family = AF_INET;
  end->group.sin_port = htons(static_cast<uint16_t>(s.port));
  if (inet_pton(AF_INET, s.group.c_str(), &end->group.sin_addr) != 1) {
    errno = EINVAL;
    return fail("--group " + s.group);
  }
  end->hear = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
  end->speak = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (end->hear < 0 || end->speak < 0) return fail("socket");
  const int one = 1, buf = 16 << 20;
  setsockopt(end->hear, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  if (setsockopt(end->hear, SOL_SOCKET, SO_RCVBUFFORCE, &buf, sizeof buf) != 0)
    setsockopt(end->hear, SOL_SOCKET, SO_RCVBUF, &buf, sizeof buf);
  sockaddr_in any{};
  any.sin_family = AF_INET;
  any.sin_port = end->group.sin_port;
  if (bind(end->hear, reinterpret_cast<sockaddr*>(&any), sizeof any) != 0) return fail("bind");
  ip_mreq mreq{};
  mreq.imr_multiaddr = end->group.sin_addr;
  if (setsockopt(end->hear, IPPROTO_IP, IP_ADD_MEMBERSHIP, &mreq, sizeof mreq) != 0)
    return fail("join " + s.group + " in " + ns_path + " (no multicast route?)");
  const unsigned char ttl = 0, loop = 1;  // to this namespace's listeners only
  setsockopt(end->speak, IPPROTO_IP, IP_MULTICAST_TTL, &ttl, sizeof ttl);
  setsockopt(end->speak, IPPROTO_IP, IP_MULTICAST_LOOP, &loop, sizeof loop);
  any.sin_port = 0;
  if (bind(end->speak, reinterpret_cast<sockaddr*>(&any), sizeof any) != 0) return fail("bind");
  socklen_t len = sizeof any;
  getsockname(end->speak, reinterpret_cast<sockaddr*>(&any), &len);
  end->speak_port = ntohs(any.sin_port);
  return true;
}

double secondsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Reads every datagram waiting at `from` and admits each into `dir`'s queue.
void hear(const End& from, link::Direction* dir, std::deque<Pending>* queue, double now_s) {
  std::vector<uint8_t> buf(65536);
  for (;;) {
    sockaddr_in src{};
    socklen_t len = sizeof src;
    const ssize_t n =
        recvfrom(from.hear, buf.data(), buf.size(), 0, reinterpret_cast<sockaddr*>(&src), &len);
    if (n < 0) return;                                     // EAGAIN: none left
    if (ntohs(src.sin_port) == from.speak_port) continue;  // our own, forwarded into it
    const uint64_t sender = (uint64_t{src.sin_addr.s_addr} << 16) | ntohs(src.sin_port);
    double leave_s = 0.0;
    if (dir->admit(sender, buf.data(), static_cast<size_t>(n), now_s, &leave_s))
      queue->push_back(Pending{leave_s, std::vector<uint8_t>(buf.begin(), buf.begin() + n)});
  }
}

// Sends the queued datagrams whose time has come; the seconds until the next one (or -1).
double speak(const End& to, std::deque<Pending>* queue, double now_s) {
  while (!queue->empty() && queue->front().leave_s <= now_s) {
    const std::vector<uint8_t>& b = queue->front().bytes;
    sendto(to.speak, b.data(), b.size(), 0, reinterpret_cast<const sockaddr*>(&to.group),
           sizeof to.group);
    queue->pop_front();
  }
  return queue->empty() ? -1.0 : queue->front().leave_s - now_s;
}

int run(const Settings& s, End ends[2]) {
  link::Direction dirs[2] = {link::Direction(s.link, static_cast<uint64_t>(s.link.seed)),
                             link::Direction(s.link, static_cast<uint64_t>(s.link.seed) + 1)};
  std::deque<Pending> queues[2];  // [0]: a -> b, [1]: b -> a
  const auto t0 = std::chrono::steady_clock::now();
  std::printf(
      "evermap-lcm-link: %s <-> %s, loss %g %%, delay %g +- %g ms, partition %g s at %g s\n",
      s.name[0].c_str(), s.name[1].c_str(), s.link.loss_pct, s.link.delay_ms, s.link.jitter_ms,
      s.link.partition_s, s.link.partition_start_s);
  std::fflush(stdout);
  while (!g_stop) {
    double wait_s = 0.1;
    for (int d = 0; d < 2; ++d) {
      const double next = speak(ends[1 - d], &queues[d], secondsSince(t0));
      if (next >= 0.0) wait_s = std::min(wait_s, next);
    }
    pollfd fds[2] = {{ends[0].hear, POLLIN, 0}, {ends[1].hear, POLLIN, 0}};
    const timespec ts{0, static_cast<long>(wait_s * 1e9)};
    if (ppoll(fds, 2, &ts, nullptr) < 0 && errno != EINTR) return fail("poll") ? 0 : 1;
    for (int d = 0; d < 2; ++d)
      if (fds[d].revents & POLLIN) hear(ends[d], &dirs[d], &queues[d], secondsSince(t0));
  }
  std::printf("link seconds %.3f\n", secondsSince(t0));
  for (int d = 0; d < 2; ++d)
    for (const std::string& l :
         link::countLines(s.name[d] + "->" + s.name[1 - d], dirs[d].counts()))
      std::printf("%s\n", l.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Settings s;
  CommandLine cli("evermap-lcm-link",
                  "A lossy link for LCM between two network namespaces (docs/deployment.md).");
  cli.value("--ns-a", &s.ns[0], "PATH", "first namespace (/proc/PID/ns/net)", /*required=*/true);
  cli.value("--ns-b", &s.ns[1], "PATH", "second namespace (/proc/PID/ns/net)", /*required=*/true);
  cli.value("--name-a", &s.name[0], "NAME", "first namespace's name in the counts (robot)");
  cli.value("--name-b", &s.name[1], "NAME", "second namespace's name in the counts (base)");
  cli.value("--group", &s.group, "ADDR", "LCM's multicast group (239.255.76.67)");
  cli.value("--port", &s.port, "N", "LCM's port (7667)").in(1, 65535);
  cli.options(&s.link, "link.");
  if (const int code = cli.parseOrExit(argc, argv); code >= 0) return code;
  try {
    std::regex check(s.link.local);
  } catch (const std::regex_error&) {
    std::fprintf(stderr, "evermap-lcm-link: link.local: \"%s\" is not a regular expression\n",
                 s.link.local.c_str());
    return 2;
  }
  End ends[2];
  for (int i = 0; i < 2; ++i)
    if (!openEnd(s, s.ns[i], &ends[i])) return 1;
  struct sigaction sa {};
  sa.sa_handler = onSignal;
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  return run(s, ends);
}
