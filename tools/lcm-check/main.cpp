// evermap-lcm-check: subscribes to every channel and checks that what arrives is exactly the
// content of an LCM log (for replays with lcm-logplayer), or lists the known message types.
//
//   evermap-lcm-check --log FILE [--ready-file PATH] [--idle-timeout-s S] [--lcm-url URL]
//   evermap-lcm-check --list-types
//
// Exits 0 when every logged message arrived intact, 1 otherwise, 2 on bad usage or input.
#include <chrono>
#include <cstdio>
#include <fstream>
#include <lcm/lcm-cpp.hpp>
#include <string>

#include "core/common/command_line.h"
#include "core/common/option_fields.h"
#include "tools/lcmlog/log_compare.h"
#include "tools/lcmlog/type_registry.h"

namespace {

// The check's one setting (--help lists it, --print-config prints it).
struct LcmCheckOptions {
  double idle_timeout_s = 10.0;
  void declareOptions(evermap::OptionList& o) {
    o.add("idle_timeout_s", &idle_timeout_s, "s", "stop after this long without a message")
        .positive();
  }
};

}  // namespace

int main(int argc, char** argv) {
  std::string log;
  std::string ready_file;
  std::string url;
  LcmCheckOptions options;
  const double& idle_timeout_s = options.idle_timeout_s;
  bool list_types = false;
  evermap::CommandLine cli("evermap-lcm-check",
                           "Checks that what arrives on LCM is exactly the content of a log.");
  cli.value("--log", &log, "FILE", "the LCM log being replayed");
  cli.value("--ready-file", &ready_file, "PATH", "written once subscribed");
  cli.options(&options);
  cli.alias("--idle-timeout-s", "idle_timeout_s", "S");
  cli.value("--lcm-url", &url, "URL", "LCM provider (default: LCM_DEFAULT_URL)");
  cli.flag("--list-types", &list_types, "print the known message types and fingerprints");
  if (const int code = cli.parseOrExit(argc, argv); code >= 0) return code;
  if (list_types) {
    for (const auto& t : evermap::messages::allTypes()) {
      std::printf("%s %lld\n", t.name.c_str(), static_cast<long long>(t.fingerprint));
    }
    return 0;
  }
  if (log.empty() || idle_timeout_s <= 0.0) {
    std::fprintf(stderr, "evermap-lcm-check: --log and a positive --idle-timeout-s are needed\n%s",
                 cli.usage().c_str());
    return 2;
  }
  auto comparator = evermap::messages::LogComparator::fromLog(log);
  if (!comparator) {
    std::fprintf(stderr, "evermap-lcm-check: %s\n", comparator.error().message.c_str());
    return 2;
  }
  lcm::LCM lcm(url);
  if (!lcm.good()) {
    std::fprintf(stderr, "evermap-lcm-check: cannot start LCM (url \"%s\")\n", url.c_str());
    return 2;
  }
  lcm::Subscription* sub = lcm.subscribeFunction(
      ".*",
      +[](const lcm::ReceiveBuffer* rbuf, const std::string& channel,
          evermap::messages::LogComparator* c) {
        c->onMessage(channel, rbuf->data, rbuf->data_size);
      },
      &*comparator);
  // LCM queues at most 30 messages per subscription by default and drops the oldest beyond
  // that: a checker must not lose any, so its queue is unbounded.
  sub->setQueueCapacity(0);
  if (!ready_file.empty()) std::ofstream(ready_file) << "ready\n";
  std::printf("evermap-lcm-check: waiting for %lld messages from %s\n",
              static_cast<long long>(comparator->expectedTotal()), log.c_str());
  std::fflush(stdout);

  using Clock = std::chrono::steady_clock;
  auto last = Clock::now();
  bool seen_any = false;
  while (!comparator->allReceived()) {
    const int r = lcm.handleTimeout(200);
    if (r < 0) {
      std::fprintf(stderr, "evermap-lcm-check: LCM receive error\n");
      break;
    }
    if (r > 0) {
      last = Clock::now();
      seen_any = true;
      continue;
    }
    // Before the first message, allow a longer start-up of the player.
    const double limit = seen_any ? idle_timeout_s : 6.0 * idle_timeout_s;
    if (std::chrono::duration<double>(Clock::now() - last).count() > limit) {
      std::fprintf(stderr, "evermap-lcm-check: nothing received for %.1f s, stopping\n", limit);
      break;
    }
  }
  const auto s = comparator->summary();
  std::printf("%s", s.table().c_str());
  std::printf("%s: %lld of %lld messages intact\n", s.complete() ? "OK" : "INCOMPLETE",
              static_cast<long long>(s.intact), static_cast<long long>(s.expected));
  return s.complete() ? 0 : 1;
}
