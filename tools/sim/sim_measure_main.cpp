// evermap-sim-measure: the measurement-level simulator (DESIGN.md section 8, docs/simulators.md).
//
//   evermap-sim-measure --config FILE [--set key=value]... --out DIR
//       write an LCM log per session (or per run), TUM ground truth and run.sim.txt into DIR
//   evermap-sim-measure --config FILE [--set key=value]... --stats [--no-load]
//       generate without writing; print figures, message counts and timings; unless --no-load,
//       drive the registration oracle with a synthetic request load (tools/sim/request_load.h)
//   evermap-sim-measure --config FILE --serve [--lcm-url URL] [--speed X]
//       publish the run on LCM (X times real time within a session; 0: as fast as possible)
//       and answer REGISTER_REQUEST from NODE_ADDED, standing in for loopclose-proc
//   evermap-sim-measure --config FILE --oracle [--lcm-url URL] [--idle-exit-s S] [--map STORE]
//       only answer registration requests, for an lcm-logplayer replay of a written run
//       (pass the run's run.sim.txt as the config: the keyframe truth is regenerated from it);
//       --map: first learn the nodes the mapper's store already holds (a restarted oracle)
//   evermap-sim-measure --config FILE --print-config
//
// Exit status: 0 done, 1 failed while running, 2 bad usage or configuration.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "core/common/clocks.h"
#include "core/common/command_line.h"
#include "core/common/key_value_file.h"
#include "core/messages/key_option.h"
#include "core/messages/outbox.h"
#include "core/common/stop_signals.h"
#include "tools/sim/oracle_server.h"
#include "tools/sim/registration_oracle.h"
#include "tools/sim/request_load.h"
#include "tools/sim/run.h"
#include "tools/sim/run_output.h"

namespace {

using evermap::sim::KeyframeTruth;
using evermap::sim::RunPlan;
using Clock = evermap::SteadyClock;
using evermap::secondsSince;

struct Args {
  std::string config;
  std::vector<std::string> sets;
  std::string out;
  std::string mode;  // out, stats, serve, oracle, print
  std::string lcm_url;
  std::string map;  // --oracle: the map store to read known nodes from
  std::string key_file;
  double speed = 0.0;
  double idle_exit_s = 0.0;
  bool load = true;
};

// Returns -1 to run, or main's exit status (usage printed).
int parseArgs(int argc, char** argv, Args* a) {
  evermap::CommandLine cli("evermap-sim-measure",
                           "The measurement-level simulator; one of --out, --stats, --serve, "
                           "--oracle, --print-config.");
  auto mode = [a](const char* m) {
    return [a, m](const std::string&) -> evermap::Status {
      if (!a->mode.empty() && a->mode != m) {
        return evermap::makeError("only one of --out, --stats, --serve, --oracle, --print-config");
      }
      a->mode = m;
      return evermap::Ok{};
    };
  };
  cli.value("--config", &a->config, "FILE", "simulation settings (config/sim-*.conf)", true);
  cli.repeated("--set", &a->sets, "KEY=VALUE", "override one setting (repeatable)");
  cli.value(
      "--out",
      [a, m = mode("out")](const std::string& v) -> evermap::Status {
        a->out = v;
        return m(v);
      },
      "DIR", "write an LCM log per session, TUM ground truth and run.sim.txt into DIR");
  bool stats = false, serve = false, oracle = false, print = false, no_load = false;
  cli.flag("--stats", &stats, "generate without writing; print figures and timings");
  cli.flag("--no-load", &no_load, "--stats without the synthetic registration load");
  cli.flag("--serve", &serve, "publish the run on LCM and answer registrations");
  cli.flag("--oracle", &oracle, "only answer registrations (for a replay of a written run)");
  cli.flag("--print-config", &print, "print every setting and exit");
  cli.value("--lcm-url", &a->lcm_url, "URL", "LCM provider (default: $LCM_DEFAULT_URL)");
  cli.value("--map", &a->map, "STORE", "--oracle: first learn the nodes the map store holds");
  evermap::messages::declareKeyOption(cli, &a->key_file);
  cli.value("--speed", &a->speed, "X", "--serve: times real time (0: as fast as possible)").min(0);
  cli.value("--idle-exit-s", &a->idle_exit_s, "S", "--oracle: exit after S s without requests")
      .min(0);
  // The settings a --config file and --set take, listed in --help (read by the simulator).
  evermap::sim::SimOptions listed;
  cli.options(&listed);
  if (const int code = cli.parseOrExit(argc, argv); code >= 0) return code;
  a->load = !no_load;
  for (auto [on, m] :
       {std::pair{stats, "stats"}, {serve, "serve"}, {oracle, "oracle"}, {print, "print"}}) {
    if (!on) continue;
    if (const auto s = mode(m)(""); !s) {
      std::fprintf(stderr, "evermap-sim-measure: %s\n%s", s.error().message.c_str(),
                   cli.usage().c_str());
      return 2;
    }
  }
  if (a->mode.empty() || a->speed < 0.0 || a->idle_exit_s < 0.0) {
    std::fprintf(stderr, "evermap-sim-measure: give one mode, and --speed / --idle-exit-s >= 0\n%s",
                 cli.usage().c_str());
    return 2;
  }
  return -1;
}

double cpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

int runStats(const RunPlan& plan, bool load) {
  evermap::sim::RegistrationOracle oracle(plan.options().oracle, plan.oracleSeed());
  evermap::sim::RequestLoad requests(oracle, evermap::sim::RequestLoadOptions{});
  double oracle_s = 0.0;
  double oracle_cpu_s = 0.0;
  evermap::sim::SessionObservers observers;
  if (load) {
    observers.on_keyframe = [&](const KeyframeTruth& k) {
      const auto t0 = Clock::now();
      const double c0 = cpuSeconds();
      requests.onKeyframe(k);
      oracle_s += secondsSince(t0);
      oracle_cpu_s += cpuSeconds() - c0;
    };
  }
  evermap::sim::NullSink null;
  const auto t0 = Clock::now();
  const double cpu0 = cpuSeconds();
  const auto summary = evermap::sim::generateRun(
      plan, [&](int) -> evermap::sim::MessageSink& { return null; }, observers);
  const double wall = secondsSince(t0);
  std::printf("%s", summary.text().c_str());
  std::printf("generation + encoding       %.2f s wall, %.2f s CPU\n", wall - oracle_s,
              cpuSeconds() - cpu0 - oracle_cpu_s);
  if (load) {
    const auto& l = requests.summary();
    std::printf("synthetic load              %lld nodes, %lld node + %lld global requests\n",
                static_cast<long long>(l.nodes_added), static_cast<long long>(l.node_requests),
                static_cast<long long>(l.global_requests));
    std::printf("%s", oracle.summary().text().c_str());
    std::printf("oracle + synthetic load     %.2f s wall, %.2f s CPU\n", oracle_s, oracle_cpu_s);
  }
  return 0;
}

int runOut(const RunPlan& plan, const std::string& folder) {
  const auto t0 = Clock::now();
  const double cpu0 = cpuSeconds();
  auto written = evermap::sim::writeRun(plan, folder);
  if (!written) {
    std::fprintf(stderr, "evermap-sim-measure: %s\n", written.error().message.c_str());
    return 1;
  }
  std::printf("%s", written->summary.text().c_str());
  std::printf("generation + writing        %.2f s wall, %.2f s CPU\n", secondsSince(t0),
              cpuSeconds() - cpu0);
  std::printf("wrote %zu log(s) and %s\n", written->logs.size(), written->sidecar.string().c_str());
  return 0;
}

// Publishes every message on LCM; between messages, answers what arrived.
class LcmSink final : public evermap::sim::MessageSink {
 public:
  LcmSink(lcm::LCM& lcm, const evermap::messages::Outbox& out, double speed,
          evermap::StopSignals& stop)
      : lcm_(lcm), out_(out), speed_(speed), stop_(stop) {}
  void startSession() { first_utime_ = -1; }
  void write(const std::string& channel, int64_t utime, const std::vector<uint8_t>& data) override {
    if (stop_.requested()) return;
    if (speed_ > 0.0) {
      if (first_utime_ < 0) {
        first_utime_ = utime;
        wall_start_ = Clock::now();
      }
      const auto due = wall_start_ + std::chrono::microseconds(
                                         static_cast<int64_t>((utime - first_utime_) / speed_));
      while (Clock::now() < due && !stop_.requested()) lcm_.handleTimeout(1);
    }
    out_.publishBytes(channel, data.data(), static_cast<int64_t>(data.size()));
    while (lcm_.handleTimeout(0) > 0) {
    }
  }

 private:
  lcm::LCM& lcm_;
  const evermap::messages::Outbox& out_;
  double speed_;
  evermap::StopSignals& stop_;
  int64_t first_utime_ = -1;
  Clock::time_point wall_start_;
};

// The LCM of a serve or oracle run and this program's signer; nullopt (the error printed,
// *code the exit status) when either cannot be had.
struct SignedLcm {
  evermap::messages::Signer signer;
  std::unique_ptr<lcm::LCM> lcm;
};
std::optional<SignedLcm> openSignedLcm(const Args& args, int* code) {
  auto signer = evermap::messages::makeSigner("evermap-sim-measure", args.key_file);
  if (!signer) {
    std::fprintf(stderr, "evermap-sim-measure: %s\n", signer.error().message.c_str());
    *code = 2;
    return std::nullopt;
  }
  auto lcm = std::make_unique<lcm::LCM>(args.lcm_url);
  if (!lcm->good()) {
    std::fprintf(stderr, "evermap-sim-measure: cannot start LCM (url \"%s\")\n",
                 args.lcm_url.c_str());
    *code = 1;
    return std::nullopt;
  }
  return SignedLcm{*signer, std::move(lcm)};
}

int runServe(const RunPlan& plan, const Args& args, const SignedLcm& link,
             evermap::StopSignals& stop) {
  lcm::LCM& lcm = *link.lcm;
  const evermap::messages::Signer& signer = link.signer;
  evermap::sim::RegistrationOracle oracle(plan.options().oracle, plan.oracleSeed());
  const evermap::messages::Outbox out(lcm, signer);
  evermap::sim::OracleServer server(lcm, oracle, signer);
  LcmSink sink(lcm, out, args.speed, stop);
  evermap::sim::SessionObservers observers;
  observers.on_keyframe = [&](const KeyframeTruth& k) { oracle.addKeyframe(k); };
  const auto summary = evermap::sim::generateRun(
      plan,
      [&](int session) -> evermap::sim::MessageSink& {
        std::printf("evermap-sim-measure: session %d\n", session);
        std::fflush(stdout);
        sink.startSession();
        return sink;
      },
      observers);
  // Late requests for the last keyframes.
  const auto end = Clock::now() + std::chrono::seconds(2);
  while (Clock::now() < end && !stop.requested()) lcm.handleTimeout(50);
  std::printf("%s", summary.text().c_str());
  std::printf("%s", oracle.summary().text().c_str());
  std::printf("answered %lld requests, dropped %lld messages\n",
              static_cast<long long>(server.answered()), static_cast<long long>(server.dropped()));
  return stop.requested() ? 1 : 0;
}

int runOracle(const RunPlan& plan, const Args& args, const SignedLcm& link,
              evermap::StopSignals& stop) {
  lcm::LCM& lcm = *link.lcm;
  const evermap::messages::Signer& signer = link.signer;
  evermap::sim::OracleOptions options = plan.options().oracle;
  options.keyframe_window_s = 0.0;  // a replay may ask about any keyframe of the run
  evermap::sim::RegistrationOracle oracle(options, plan.oracleSeed());
  evermap::sim::SessionObservers observers;
  observers.on_keyframe = [&](const KeyframeTruth& k) { oracle.addKeyframe(k); };
  evermap::sim::NullSink null;
  (void)evermap::sim::generateRun(
      plan, [&](int) -> evermap::sim::MessageSink& { return null; }, observers);
  int64_t stored_nodes = 0;
  if (!args.map.empty()) {
    auto told = evermap::sim::loadStoredNodes(oracle, args.map);
    if (!told) {
      std::fprintf(stderr, "evermap-sim-measure: %s\n", told.error().message.c_str());
      return 1;
    }
    stored_nodes = *told;
  }
  evermap::sim::OracleServer server(lcm, oracle, signer);
  std::printf(
      "evermap-sim-measure: oracle ready, %lld keyframes known, %lld nodes from the map store\n",
      static_cast<long long>(oracle.summary().keyframes), static_cast<long long>(stored_nodes));
  std::fflush(stdout);
  auto last = Clock::now();
  int64_t seen = 0;
  while (!stop.requested()) {
    lcm.handleTimeout(100);
    if (server.answered() != seen) {
      seen = server.answered();
      last = Clock::now();
    }
    if (args.idle_exit_s > 0.0 && secondsSince(last) > args.idle_exit_s) break;
  }
  std::printf("%s", oracle.summary().text().c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Args args;
  if (const int code = parseArgs(argc, argv, &args); code >= 0) return code;
  evermap::StopSignals stop;  // SIGINT/SIGTERM end a serve or oracle run
  auto options =
      evermap::sim::loadConfig(evermap::sim::loadSimOptions, args.config, args.sets, "--set");
  if (!options) {
    std::fprintf(stderr, "evermap-sim-measure: %s\n", options.error().message.c_str());
    return 2;
  }
  if (args.mode == "print") {
    std::printf("%s", options->toConfigText().c_str());
    return 0;
  }
  auto plan = RunPlan::create(*options);
  if (!plan) {
    std::fprintf(stderr, "evermap-sim-measure: %s\n", plan.error().message.c_str());
    return 2;
  }
  if (args.mode == "stats") return runStats(*plan, args.load);
  if (args.mode == "out") return runOut(*plan, args.out);
  int code = 0;
  auto link = openSignedLcm(args, &code);
  if (!link) return code;
  if (args.mode == "serve") return runServe(*plan, args, *link, stop);
  return runOracle(*plan, args, *link, stop);
}
