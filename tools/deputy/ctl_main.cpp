// evermap-deputy-ctl: operates evermap deputies over LCM without lcm-spy (docs/deputy.md).
//
//   evermap-deputy-ctl [--lcm-url URL] [--host NAME] [--timeout-s S] COMMAND ...
//     status [--tsv]                   the latest status of every deputy
//     start TARGET...                  TARGET: NAME | cmd NAME | group NAME | everything
//     stop TARGET...
//     restart TARGET...
//     wait running|stopped TARGET...   until every target is in that state
//     output [NAME...]                 print DEPUTY_OUTPUT lines as they arrive (Ctrl-C ends)
//
// Exits 0 on success, 1 when no deputy answers, a target is unknown or an order is not
// acknowledged in time, 2 on bad usage.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <lcm/lcm-cpp.hpp>
#include <set>
#include <string>
#include <vector>

#include <evermap/deputy_output_t.hpp>

#include "core/common/command_line.h"
#include "core/common/option_fields.h"
#include "core/messages/channels.h"
#include "core/messages/inbox.h"
#include "core/messages/key_option.h"
#include "tools/deputy/deputy_client.h"

namespace {

using namespace evermap::deputy;

// The client's settings (--help lists them, --print-config prints them).
struct CtlOptions {
  DeputyClientOptions client;
  void declareOptions(evermap::OptionList& o) {
    o.add("timeout_s", &client.timeout_s, "s",
          "how long to wait for a status or for each acknowledgement")
        .positive();
    o.add("settle_s", &client.settle_s, "s",
          "after the first status, listen this long for other hosts")
        .positive();
  }
};

// The command line: the options, then COMMAND and its words.
struct CtlArgs {
  std::string lcm_url, key_file;
  CtlOptions tool;
  DeputyClientOptions& options = tool.client;
  std::vector<std::string> rest;
  bool tsv = false;
};

void declareCommandLine(evermap::CommandLine& cli, CtlArgs* a) {
  cli.value("--lcm-url", &a->lcm_url, "URL", "LCM provider (default: $LCM_DEFAULT_URL)");
  cli.value("--host", &a->options.host, "NAME", "only the deputy of this host (default: all)");
  evermap::messages::declareKeyOption(cli, &a->key_file);
  cli.options(&a->tool);
  cli.alias("--timeout-s", "timeout_s", "S");
  cli.flag("--tsv", &a->tsv, "status: tab-separated values instead of a table");
  cli.positional(&a->rest, "COMMAND ...", "the command and its words (above)");
}

std::vector<CtlTarget> parseTargets(const std::vector<std::string>& args) {
  std::vector<CtlTarget> targets;
  for (size_t i = 0; i < args.size(); ++i) {
    CtlTarget t;
    if ((args[i] == "cmd" || args[i] == "group") && i + 1 < args.size()) {
      t.kind = args[i] == "cmd" ? CtlTarget::Kind::kCommand : CtlTarget::Kind::kGroup;
      t.name = args[++i];
    } else if (args[i] == "everything") {
      t.kind = CtlTarget::Kind::kEverything;
    } else {
      t.name = args[i];
    }
    targets.push_back(std::move(t));
  }
  return targets;
}

int fail(const evermap::Error& e) {
  std::fprintf(stderr, "evermap-deputy-ctl: %s\n", e.message.c_str());
  return 1;
}

struct OutputPrinter {
  std::set<std::string> names;
  void onOutput(const evermap::deputy_output_t* m) {
    if (!names.empty() && !names.count(m->name)) return;
    size_t start = 0;
    while (start < m->text.size()) {
      size_t end = m->text.find('\n', start);
      if (end == std::string::npos) end = m->text.size();
      std::printf("[%s/%s] %.*s\n", m->host.c_str(), m->name.c_str(), static_cast<int>(end - start),
                  m->text.c_str() + start);
      start = end + 1;
    }
    std::fflush(stdout);
  }
};

// output: DEPUTY_OUTPUT lines of the named processes (all without names) until interrupted.
int printOutput(lcm::LCM& lcm, const std::vector<std::string>& names,
                const evermap::messages::Signer& signer) {
  OutputPrinter printer;
  printer.names.insert(names.begin(), names.end());
  evermap::messages::Inbox::Options input;
  input.process = "evermap-deputy-ctl";
  input.time.window_s = 0.0;  // the deputy's wall clock
  input.signer = signer;
  evermap::messages::Inbox inbox(lcm, input);
  inbox.shareChannel(evermap::channels::kDeputyOutput);
  inbox.subscribe<evermap::deputy_output_t>(
      evermap::channels::kDeputyOutput,
      [&printer](const evermap::deputy_output_t& m) { printer.onOutput(&m); });
  while (lcm.handle() == 0) {
  }
  return 1;
}

// Sends the order of `command` (none for status); -1 when sent and acknowledged, else the
// exit status (2 for words that do not fit the command).
int sendOrder(DeputyClient& client, const std::string& command,
              const std::vector<std::string>& args) {
  if (command == "status") return args.empty() ? -1 : 2;
  if (command == "start" || command == "stop" || command == "restart") {
    if (args.empty()) return 2;
    const auto targets = parseTargets(args);
    const auto s = command == "start"  ? client.start(targets)
                   : command == "stop" ? client.stop(targets)
                                       : client.restart(targets);
    return s ? -1 : fail(s.error());
  }
  if (command == "wait") {
    if (args.size() < 2 || (args[0] != "running" && args[0] != "stopped")) return 2;
    const auto s =
        client.waitFor(parseTargets({args.begin() + 1, args.end()}), args[0] == "running");
    return s ? -1 : fail(s.error());
  }
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  CtlArgs a;
  evermap::CommandLine cli(
      "evermap-deputy-ctl",
      "Operates evermap deputies over LCM (docs/deputy.md). COMMAND is one of\n"
      "  status [--tsv]                   the latest status of every deputy\n"
      "  start|stop|restart TARGET...     TARGET: NAME | cmd NAME | group NAME | everything\n"
      "  wait running|stopped TARGET...   until every target is in that state\n"
      "  output [NAME...]                 print DEPUTY_OUTPUT lines as they arrive (Ctrl-C ends)");
  declareCommandLine(cli, &a);
  if (const int code = cli.parseOrExit(argc, argv); code >= 0) return code;
  auto usage = [&cli]() {
    std::fputs(cli.usage().c_str(), stderr);
    return 2;
  };
  if (a.rest.empty() || !a.options.validate()) return usage();
  const std::string command = a.rest[0];
  const std::vector<std::string> args(a.rest.begin() + 1, a.rest.end());
  lcm::LCM lcm(a.lcm_url);
  if (!lcm.good()) {
    std::fprintf(stderr, "evermap-deputy-ctl: cannot start LCM (url \"%s\")\n", a.lcm_url.c_str());
    return 1;
  }
  auto signer = evermap::messages::makeSigner("evermap-deputy-ctl", a.key_file);
  if (!signer) return fail(signer.error());
  a.options.signer = *signer;
  if (command == "output") return printOutput(lcm, args, *signer);
  DeputyClient client(lcm, a.options);
  if (const int code = sendOrder(client, command, args); code >= 0) {
    return code == 2 ? usage() : code;
  }
  std::vector<evermap::deputy_status_t> statuses;
  if (command == "status") {
    auto gathered = client.gather();
    if (!gathered) return fail(gathered.error());
    statuses = std::move(*gathered);
  } else {
    for (const auto& [host, s] : client.latest()) statuses.push_back(s);  // fresh: just acked
  }
  std::printf("%s", formatStatusTable(statuses, a.tsv).c_str());
  return 0;
}
