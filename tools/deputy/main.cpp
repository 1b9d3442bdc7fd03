// evermap-deputy: starts and supervises the processes of a procman configuration, publishes
// their status and output on LCM and obeys orders (docs/deputy.md).
//
//   evermap-deputy CONFIG --log-dir DIR [--host NAME] [--script NAME | --start-all]
//                  [--exit-after-script] [--lcm-url URL] [--no-output] [--quiet]
//                  [--backoff-initial-ms MS] [--backoff-max-ms MS] [--stable-after-s S]
//                  [--max-log-mb MB]
//   evermap-deputy CONFIG --check
//
// Exits 0 after a clean stop (SIGINT/SIGTERM/SIGHUP; a second one kills at once), 2 on bad usage,
// a malformed configuration or when LCM cannot start.
#include <signal.h>
#include <sys/signalfd.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <lcm/lcm-cpp.hpp>
#include <string>

#include "core/common/command_line.h"
#include "core/common/option_fields.h"
#include "core/messages/key_option.h"
#include "tools/deputy/config.h"
#include "tools/deputy/deputy_node.h"
#include "tools/deputy/script_runner.h"
#include "tools/deputy/supervisor.h"

namespace {

using namespace evermap::deputy;

void printConfig(const Config& config, const std::string& host) {
  const auto mine = config.commandsForHost(host);
  std::printf("%s: %zu commands (%zu for host \"%s\"), %zu groups, %zu scripts\n",
              config.source.c_str(), config.commands.size(), mine.size(), host.c_str(),
              config.groups.size(), config.scripts.size());
  for (const CommandSpec& c : config.commands) {
    std::printf("  cmd %-24s group=%-16s host=%-10s respawn=%s stop=%d/%ds delay=%dms\n    %s\n",
                ("\"" + c.name + "\"").c_str(), c.group.empty() ? "-" : c.group.c_str(),
                c.host.empty() ? "-" : c.host.c_str(), c.auto_respawn ? "yes" : "no", c.stop_signal,
                c.stop_time_allowed_s, c.start_delay_ms, c.exec.c_str());
  }
  for (const Script& s : config.scripts) {
    std::printf("  script \"%s\": %zu actions\n", s.name.c_str(), s.actions.size());
  }
}

std::string machineName() {
  char buf[256] = {};
  if (::gethostname(buf, sizeof buf - 1) != 0 || buf[0] == '\0') return "localhost";
  return buf;
}

// The supervision's settings (--help lists them, --print-config prints them).
struct DeputyOptions {
  BackoffOptions backoff;
  OutputThrottleOptions output;
  double max_log_mb = 256.0;  // SupervisorOptions::max_log_bytes

  void declareOptions(evermap::OptionList& o) {
    o.nest("", &backoff);
    o.nest("output.", &output);
    o.add("max_log_mb", &max_log_mb, "MiB", "rotate a process log beyond this size").positive();
  }
};

// The command line of a deputy.
struct DeputyArgs {
  std::string config_path, log_dir, host, script, lcm_url, key_file;
  bool check = false, start_all = false, exit_after_script = false, quiet = false;
  bool no_output = false;
  DeputyOptions options;
  const BackoffOptions& backoff = options.backoff;
};

// -1 to run, else the exit status (usage and errors already printed).
int parseCommandLine(int argc, char** argv, DeputyArgs* a) {
  std::vector<std::string> positional;
  evermap::CommandLine cli("evermap-deputy",
                           "Spawns and watches the processes of a bot-procman config (CONFIG).");
  cli.positional(&positional, "CONFIG", "the process configuration (config/*.pmd)");
  cli.value("--log-dir", &a->log_dir, "DIR", "one output log per process (needed unless --check)");
  cli.value("--host", &a->host, "NAME", "this deputy's host name (default: the machine's)");
  cli.value("--script", &a->script, "NAME", "run this script of the config");
  cli.flag("--start-all", &a->start_all, "start every command at once");
  cli.flag("--exit-after-script", &a->exit_after_script, "stop everything when the script ends");
  cli.value("--lcm-url", &a->lcm_url, "URL", "LCM provider (default: $LCM_DEFAULT_URL)");
  cli.flag("--no-output", &a->no_output, "do not publish output lines on LCM");
  evermap::messages::declareKeyOption(cli, &a->key_file);
  cli.flag("--quiet", &a->quiet, "print less");
  cli.options(&a->options);
  cli.alias("--backoff-initial-ms", "backoff_initial_ms", "MS");
  cli.alias("--backoff-max-ms", "backoff_max_ms", "MS");
  cli.alias("--stable-after-s", "stable_after_s", "S");
  cli.alias("--max-log-mb", "max_log_mb", "MB");
  cli.flag("--check", &a->check, "parse CONFIG, print it and exit");
  if (const int code = cli.parseOrExit(argc, argv); code >= 0) return code;
  if (positional.size() == 1) a->config_path = positional.front();
  if (positional.size() != 1 || (!a->check && a->log_dir.empty()) ||
      (a->start_all && !a->script.empty()) || (a->exit_after_script && a->script.empty())) {
    std::fprintf(stderr,
                 "evermap-deputy: one CONFIG, --log-dir unless --check, --start-all or --script, "
                 "--exit-after-script only with --script\n%s",
                 cli.usage().c_str());
    return 2;
  }
  if (a->host.empty()) a->host = machineName();
  return -1;
}

// SIGINT, SIGTERM and SIGHUP arrive on a signalfd, read in the main loop (no handler, no
// global). Children get an empty mask (posix_spawn in child_process.cpp). -1 on failure.
int stopSignalFd() {
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGINT);
  sigaddset(&stop_signals, SIGTERM);
  sigaddset(&stop_signals, SIGHUP);  // the terminal went away: stop cleanly, not abruptly
  sigprocmask(SIG_BLOCK, &stop_signals, nullptr);
  const int signal_fd = ::signalfd(-1, &stop_signals, SFD_NONBLOCK | SFD_CLOEXEC);
  if (signal_fd < 0) std::perror("evermap-deputy: signalfd");
  return signal_fd;
}

// Serves LCM and the processes until everything has stopped: a first signal (or the end of
// the script, with --exit-after-script) stops every process, a second one kills them.
void superviseUntilStopped(DeputyNode& node, Supervisor& sup, const DeputyArgs& a, int signal_fd) {
  while (true) {
    node.spinOnce(500, signal_fd);
    signalfd_siginfo info{};
    while (::read(signal_fd, &info, sizeof info) == static_cast<ssize_t>(sizeof info)) {
      if (!sup.shuttingDown()) {
        std::fprintf(stderr, "evermap-deputy: %s: stopping every process\n",
                     strsignal(static_cast<int>(info.ssi_signo)));
        sup.beginShutdown();
      } else {
        std::fprintf(stderr, "evermap-deputy: second signal: SIGKILL to every process\n");
        sup.killAll();
      }
    }
    if (a.exit_after_script && !node.scriptRunning() && !sup.shuttingDown()) {
      std::fprintf(stderr, "evermap-deputy: script \"%s\" done: stopping every process\n",
                   a.script.c_str());
      sup.beginShutdown();
    }
    if (sup.shuttingDown() && sup.allStopped()) break;
  }
}

void printFinalCounts(const DeputyNode& node, const Supervisor& sup) {
  int restarts = 0;
  for (const ProcessStatus& s : sup.status()) restarts += s.restarts;
  const auto& c = node.counters();
  std::fprintf(stderr,
               "evermap-deputy: all stopped; %d automatic restarts, %lld orders applied, "
               "%lld output lines not sent (rate limit)\n",
               restarts, static_cast<long long>(c.orders_applied),
               static_cast<long long>(node.outputLinesDropped()));
  std::fprintf(stderr, "evermap-deputy: input: %s\n", node.inbox().summary().c_str());
}

// The node's options from the command line; false (error printed) when they do not hold.
bool nodeOptions(const DeputyArgs& a, DeputyNodeOptions* node_options) {
  node_options->host = a.host;
  node_options->publish_output = !a.no_output;
  node_options->print_notes = !a.quiet;
  node_options->output = a.options.output;
  auto signer = evermap::messages::makeSigner("evermap-deputy", a.key_file);
  if (!signer) {
    std::fprintf(stderr, "evermap-deputy: %s\n", signer.error().message.c_str());
    return false;
  }
  node_options->signer = *signer;
  if (auto ok = node_options->validate(); !ok) {
    std::fprintf(stderr, "evermap-deputy: %s\n", ok.error().message.c_str());
    return false;
  }
  return true;
}

// Supervises this host's commands of `config` until stopped; main's exit status.
int runDeputy(const Config& config, const DeputyArgs& a, int signal_fd) {
  const auto commands = config.commandsForHost(a.host);
  SupervisorOptions supervisor_options;
  supervisor_options.log_dir = a.log_dir;
  supervisor_options.max_log_bytes = static_cast<int64_t>(a.options.max_log_mb * (1 << 20));
  supervisor_options.backoff = a.backoff;
  auto supervisor = Supervisor::create(commands, supervisor_options);
  if (!supervisor) {
    std::fprintf(stderr, "evermap-deputy: %s\n", supervisor.error().message.c_str());
    return 2;
  }
  lcm::LCM lcm(a.lcm_url);
  if (!lcm.good()) {
    std::fprintf(stderr, "evermap-deputy: cannot start LCM (url \"%s\")\n", a.lcm_url.c_str());
    return 2;
  }
  DeputyNodeOptions node_options;
  if (!nodeOptions(a, &node_options)) return 2;
  DeputyNode node(lcm, **supervisor, node_options);
  std::fprintf(stderr, "evermap-deputy: host \"%s\": %zu of %zu commands from %s, logs in %s, %s\n",
               a.host.c_str(), commands.size(), config.commands.size(), a.config_path.c_str(),
               a.log_dir.c_str(), a.backoff.describe().c_str());
  if (commands.empty()) {
    std::fprintf(stderr,
                 "evermap-deputy: warning: no command of %s is for host \"%s\" "
                 "(set --host, or host = \"localhost\" in the file)\n",
                 a.config_path.c_str(), a.host.c_str());
  }
  if (!a.script.empty()) {
    auto runner = ScriptRunner::create(config, a.script);
    if (!runner) {
      std::fprintf(stderr, "evermap-deputy: %s\n", runner.error().message.c_str());
      return 2;
    }
    node.runScript(std::move(*runner));
  }
  if (a.start_all) {
    for (const CommandSpec& c : commands) (void)(*supervisor)->start(c.name);
  }
  superviseUntilStopped(node, **supervisor, a, signal_fd);
  node.publishStatus();
  printFinalCounts(node, **supervisor);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  DeputyArgs a;
  if (const int code = parseCommandLine(argc, argv, &a); code >= 0) return code;
  auto config = loadConfig(a.config_path);
  if (!config) {
    std::fprintf(stderr, "evermap-deputy: %s\n", config.error().message.c_str());
    return 2;
  }
  if (a.check) {
    printConfig(*config, a.host);
    return 0;
  }
  const int signal_fd = stopSignalFd();
  if (signal_fd < 0) return 2;
  return runDeputy(*config, a, signal_fd);
}
