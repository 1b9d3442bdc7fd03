// What the deputy's work costs: starting and reaping a child (directly and through /bin/sh),
// one /proc scan for CPU and memory, the output throttle per line, parsing a configuration.
//
//   build/bin/deputy_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <sys/wait.h>
#include <unistd.h>

#include "tools/deputy/child_process.h"
#include "tools/deputy/config.h"
#include "tools/deputy/output_throttle.h"
#include "tools/deputy/proc_stats.h"

namespace {

using namespace evermap::deputy;

void spawnAndReap(benchmark::State& state, const char* exec) {
  const LaunchPlan plan = planLaunch(exec);
  for (auto _ : state) {
    auto child = spawnChild(plan);
    if (!child) {
      state.SkipWithError(child.error().message.c_str());
      return;
    }
    int status = 0;
    ::waitpid(child->pid, &status, 0);
    child->closeFds();
  }
}

void BM_SpawnAndReapDirect(benchmark::State& state) { spawnAndReap(state, "true"); }
BENCHMARK(BM_SpawnAndReapDirect)->Unit(benchmark::kMicrosecond);

void BM_SpawnAndReapViaShell(benchmark::State& state) { spawnAndReap(state, "true; true"); }
BENCHMARK(BM_SpawnAndReapViaShell)->Unit(benchmark::kMicrosecond);

// One status period's measurement: a full /proc scan for five process groups.
void BM_SampleFiveGroups(benchmark::State& state) {
  std::set<pid_t> groups = {::getpgrp(), 1, 2, 3, 4};
  for (auto _ : state) benchmark::DoNotOptimize(sampleGroups(groups));
}
BENCHMARK(BM_SampleFiveGroups)->Unit(benchmark::kMicrosecond);

void BM_ThrottleLine(benchmark::State& state) {
  OutputThrottleOptions o;
  o.max_bytes_per_s = 1e12;  // measure the bookkeeping, not the dropping
  o.burst_bytes = 1e12;
  OutputThrottle t(o);
  const std::string line = "vo-proc: frame 1234 tracked 312 features, 287 inliers";
  auto now = OutputThrottle::Clock::now();
  int64_t n = 0;
  for (auto _ : state) {
    t.addLine("vo-proc", line, now);
    if (++n % 64 == 0) benchmark::DoNotOptimize(t.takeDue(now, true));
  }
  state.SetItemsProcessed(n);
}
BENCHMARK(BM_ThrottleLine);

void BM_ParsePipelineConfig(benchmark::State& state) {
  std::string text;
  for (int i = 0; i < 20; ++i) {
    text += "group \"g" + std::to_string(i) + "\" {\n";
    for (int j = 0; j < 5; ++j) {
      text += "  cmd \"c" + std::to_string(i) + "-" + std::to_string(j) +
              "\" { exec = \"exec build/bin/evermap-vo-proc --x 1\"; host = \"robot\"; "
              "auto_respawn = \"true\"; stop_signal = 15; stop_time_allowed = 5; }\n";
    }
    text += "}\n";
  }
  text += "script \"go\" {\n";
  for (int i = 0; i < 20; ++i)
    text += "  start group \"g" + std::to_string(i) + "\" wait \"running\";\n";
  text += "}\n";
  for (auto _ : state) {
    auto c = parseConfig(text, "bench.pmd");
    if (!c) state.SkipWithError(c.error().message.c_str());
    benchmark::DoNotOptimize(c);
  }
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * text.size()));
}
BENCHMARK(BM_ParsePipelineConfig)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
