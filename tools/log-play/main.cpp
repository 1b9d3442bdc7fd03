// evermap-log-play: replays LCM logs as an evermap process, each message in this process's
// envelope (core/messages/envelope.h) — signed when a key is given. With a key configured,
// the processes refuse what lcm-logplayer replays (no envelope, no MAC) and what an old
// recording carries (its senders' MACs are valid but their time is outside the replay window):
// this is how a sensor log is replayed then (docs/lcm.md, "Senders and the key").
//
//   evermap-log-play --key evermap.key --speed 4 session.lcmlog
//
// Messages go out in the logs' order, paced by the events' timestamps over `--speed` (0: as
// fast as possible); an envelope recorded in the log is replaced by this process's. Exit
// status: 0 when every log was replayed, 1 a damaged log or LCM failure, 2 bad command line or
// key.
#include <chrono>
#include <cstdio>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "core/common/command_line.h"
#include "core/common/stop_signals.h"
#include "core/messages/key_option.h"
#include "core/messages/outbox.h"
#include "tools/lcmlog/log_reader.h"

namespace {

using Clock = std::chrono::steady_clock;

struct Args {
  std::vector<std::string> logs;
  std::string lcm_url, key_file, channels;
  double speed = 1.0;
};

int parse(int argc, char** argv, Args* a) {
  evermap::CommandLine cli("evermap-log-play",
                           "Replays LCM logs in this process's envelope (signed with --key).");
  cli.positional(&a->logs, "LOG", "LCM logs, replayed one after the other");
  cli.value("--speed", &a->speed, "X", "times real time (default 1; 0: as fast as possible)")
      .min(0);
  cli.value("--channels", &a->channels, "A,B", "only these channels (default: all)");
  cli.value("--lcm-url", &a->lcm_url, "URL", "LCM provider (default: $LCM_DEFAULT_URL)");
  evermap::messages::declareKeyOption(cli, &a->key_file);
  if (const int code = cli.parseOrExit(argc, argv); code >= 0) return code;
  if (a->logs.empty()) {
    std::fprintf(stderr, "evermap-log-play: no LOG given\n%s", cli.flagUsage().c_str());
    return 2;
  }
  return -1;
}

// Replays one log; the number of messages sent, or the log's damage.
evermap::Expected<int64_t> play(const std::string& file, const evermap::messages::Outbox& out,
                                const std::set<std::string>& only, double speed,
                                evermap::StopSignals& stop) {
  auto log = evermap::messages::LogReader::open(file);
  if (!log) return log.error();
  int64_t sent = 0, first = -1;
  const Clock::time_point start = Clock::now();
  while (const auto* e = log->next()) {
    if (stop.requested()) break;
    if (!only.empty() && !only.count(e->channel)) continue;
    if (first < 0) first = e->timestamp;
    if (speed > 0.0) {
      const auto due =
          start + std::chrono::microseconds(static_cast<int64_t>((e->timestamp - first) / speed));
      std::this_thread::sleep_until(due);
    }
    if (out.publishBytes(e->channel, e->data, e->datalen) != 0)
      return evermap::makeError("LCM publish failed on ", e->channel);
    ++sent;
  }
  if (evermap::Status s = log->status(); !s) return s.error();
  return sent;
}

}  // namespace

int main(int argc, char** argv) {
  Args args;
  if (const int code = parse(argc, argv, &args); code >= 0) return code;
  evermap::StopSignals stop;
  auto signer = evermap::messages::makeSigner("evermap-log-play", args.key_file);
  if (!signer) {
    std::fprintf(stderr, "evermap-log-play: %s\n", signer.error().message.c_str());
    return 2;
  }
  lcm::LCM lcm(args.lcm_url);
  if (!lcm.good()) {
    std::fprintf(stderr, "evermap-log-play: cannot open LCM \"%s\"\n", args.lcm_url.c_str());
    return 1;
  }
  const evermap::messages::Outbox out(lcm, *signer);
  std::set<std::string> only;
  std::stringstream list(args.channels);
  for (std::string c; std::getline(list, c, ',');) {
    if (!c.empty()) only.insert(c);
  }
  for (const std::string& file : args.logs) {
    auto sent = play(file, out, only, args.speed, stop);
    if (!sent) {
      std::fprintf(stderr, "evermap-log-play: %s\n", sent.error().message.c_str());
      return 1;
    }
    std::printf("evermap-log-play: %s: %lld messages as %s%s\n", file.c_str(),
                static_cast<long long>(*sent), signer->sender().toString().c_str(),
                signer->key() ? ", signed" : "");
    std::fflush(stdout);
    if (stop.requested()) break;
  }
  return 0;
}
