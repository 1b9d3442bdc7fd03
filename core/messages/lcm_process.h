#pragma once
// The frame of an LCM process's main() that imu-proc and elevator-proc share: the command line
// (with --lcm-url, --key and --print-options for --print-config), the LCM provider, one Inbox,
// one Outbox (what the process publishes) and the loop that handles messages until
// SIGINT/SIGTERM.
//
//   LcmProcess process("evermap-x-proc", "Subscribes A, publishes B.");
//   process.cli().options(&settings);
//   if (const int code = process.start(argc, argv); code >= 0) return code;
//   process.inbox(capacity, window_s).subscribe<a_t>(...);
//   process.run();
//
// Threading: everything on the caller's thread; construct it first in main() (it blocks
// SIGINT/SIGTERM, core/common/stop_signals.h).

#include <optional>
#include <string>

#include <lcm/lcm-cpp.hpp>

#include "core/common/command_line.h"
#include "core/common/stop_signals.h"
#include "core/messages/inbox.h"
#include "core/messages/outbox.h"

namespace evermap::messages {

class LcmProcess {
 public:
  LcmProcess(std::string name, std::string summary);

  // Declare the process's own options here before start().
  CommandLine& cli() { return cli_; }
  // Parses the command line, reads the key, then opens LCM: -1 to run, else the exit status
  // (that of CommandLine::parseOrExit, 2 for a bad key file, or 1 with "<name>: cannot open
  // LCM "<url>"" on stderr).
  int start(int argc, char** argv);

  // After start().
  lcm::LCM& lcm() { return *lcm_; }
  const Outbox& outbox() const { return *outbox_; }
  // The process's Inbox, made on the first call: `queue_capacity` messages queued per
  // subscription, the time guard's window `time_window_s` (0: off).
  Inbox& inbox(int queue_capacity, double time_window_s);
  // Handles LCM until SIGINT/SIGTERM or an LCM failure, publishing the inbox's INPUT_STATS
  // once a second; then prints "<name>: input: <summary>" on stderr.
  void run();

 private:
  std::string name_;
  StopSignals stop_;
  CommandLine cli_;
  std::string url_;
  std::string key_file_;
  Signer signer_;
  std::optional<lcm::LCM> lcm_;
  std::optional<Outbox> outbox_;
  std::optional<Inbox> inbox_;
};

}  // namespace evermap::messages
