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

#include "core/messages/channels.h"
#include "core/messages/inbox.h"
#include "tools/deputy/deputy_client.h"

namespace {

using namespace evermap::deputy;

void usage() {
  std::fprintf(stderr,
               "usage: evermap-deputy-ctl [--lcm-url URL] [--host NAME] [--timeout-s S] COMMAND\n"
               "  status [--tsv]\n"
               "  start|stop|restart TARGET...     TARGET: NAME | cmd NAME | group NAME | "
               "everything\n"
               "  wait running|stopped TARGET...\n"
               "  output [NAME...]\n");
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

}  // namespace

int main(int argc, char** argv) {
  std::string lcm_url;
  DeputyClientOptions options;
  std::vector<std::string> rest;
  bool tsv = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "evermap-deputy-ctl: %s needs a value\n", a.c_str());
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--lcm-url")
      lcm_url = next();
    else if (a == "--host")
      options.host = next();
    else if (a == "--timeout-s") {
      const std::string v = next();
      char* end = nullptr;
      options.timeout_s = std::strtod(v.c_str(), &end);
      if (v.empty() || *end != '\0' || !std::isfinite(options.timeout_s) ||
          !(options.timeout_s > 0)) {
        std::fprintf(stderr,
                     "evermap-deputy-ctl: bad --timeout-s: \"%s\" is not a finite number > 0\n",
                     v.c_str());
        return 2;
      }
    } else if (a == "--tsv")
      tsv = true;
    else if (a == "-h" || a == "--help") {
      usage();
      return 0;
    } else
      rest.push_back(a);
  }
  if (rest.empty() || !options.validate()) {
    usage();
    return 2;
  }
  const std::string command = rest[0];
  const std::vector<std::string> args(rest.begin() + 1, rest.end());
  lcm::LCM lcm(lcm_url);
  if (!lcm.good()) {
    std::fprintf(stderr, "evermap-deputy-ctl: cannot start LCM (url \"%s\")\n", lcm_url.c_str());
    return 1;
  }

  if (command == "output") {
    OutputPrinter printer;
    printer.names.insert(args.begin(), args.end());
    evermap::messages::Inbox::Options input;
    input.process = "evermap-deputy-ctl";
    input.time.window_s = 0.0;  // the deputy's wall clock
    evermap::messages::Inbox inbox(lcm, input);
    inbox.subscribe<evermap::deputy_output_t>(
        evermap::channels::kDeputyOutput,
        [&printer](const evermap::deputy_output_t& m) { printer.onOutput(&m); });
    while (lcm.handle() == 0) {
    }
    return 1;
  }

  DeputyClient client(lcm, options);
  if (command == "status") {
    if (!args.empty()) {
      usage();
      return 2;
    }
  } else if (command == "start" || command == "stop" || command == "restart") {
    if (args.empty()) {
      usage();
      return 2;
    }
    const auto targets = parseTargets(args);
    const auto s = command == "start"  ? client.start(targets)
                   : command == "stop" ? client.stop(targets)
                                       : client.restart(targets);
    if (!s) return fail(s.error());
  } else if (command == "wait") {
    if (args.size() < 2 || (args[0] != "running" && args[0] != "stopped")) {
      usage();
      return 2;
    }
    const auto s =
        client.waitFor(parseTargets({args.begin() + 1, args.end()}), args[0] == "running");
    if (!s) return fail(s.error());
  } else {
    usage();
    return 2;
  }
  std::vector<evermap::deputy_status_t> statuses;
  if (command == "status") {
    auto gathered = client.gather();
    if (!gathered) return fail(gathered.error());
    statuses = std::move(*gathered);
  } else {
    for (const auto& [host, s] : client.latest()) statuses.push_back(s);  // fresh: just acked
  }
  std::printf("%s", formatStatusTable(statuses, tsv).c_str());
  return 0;
}
