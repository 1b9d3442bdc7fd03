// Throughput of imu-proc's attitude filter and elevator-proc's tracker, per IMU sample, on a
// synthetic building run (tools/imu-elevator-run/ride_simulator.h) at 200 Hz and on the EuRoC IMU.

#include <benchmark/benchmark.h>

#include "elevator-proc/elevator_tracker.h"
#include "imu-proc/attitude_filter.h"
#include "tools/imu-elevator-run/ride_simulator.h"

namespace {

using namespace evermap;

const elevator::SimulatedRun& run() {
  static const elevator::SimulatedRun r = [] {
    elevator::RideSimulatorOptions o;
    o.rate_hz = 200.0;
    return elevator::simulateRun(o, elevator::randomScript(o, 4, 3));
  }();
  return r;
}

void BM_AttitudeFilterPerSample(benchmark::State& state) {
  const auto& samples = run().samples;
  for (auto _ : state) {
    imu::AttitudeFilter f;
    for (const auto& s : samples) benchmark::DoNotOptimize(f.add(s));
  }
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(samples.size()));
}
BENCHMARK(BM_AttitudeFilterPerSample)->Unit(benchmark::kMillisecond);

void BM_ElevatorTrackerPerSample(benchmark::State& state) {
  const auto& samples = run().samples;
  // The attitudes once, so only the tracker is timed.
  std::vector<imu::Attitude> att;
  imu::AttitudeFilter f;
  for (const auto& s : samples) {
    f.add(s);
    att.push_back(f.initialized() ? f.attitude() : imu::Attitude{});
  }
  for (auto _ : state) {
    elevator::ElevatorTracker t;
    for (size_t i = 0; i < samples.size(); ++i)
      benchmark::DoNotOptimize(t.add(samples[i], &att[i]));
  }
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(samples.size()));
}
BENCHMARK(BM_ElevatorTrackerPerSample)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
