// Measurement-level simulator speed: planning and generating one session of a paper-scale run
// (the settings of config/sim-paper-scale.conf that matter for speed), and the registration
// oracle answering requests against a map of the paper's size. The full paper-scale figures
// come from `evermap-sim-measure --config config/sim-paper-scale.conf --stats`
// (docs/simulators.md).
#include <benchmark/benchmark.h>

#include "tools/sim/message_sink.h"
#include "tools/sim/registration_oracle.h"
#include "tools/sim/run.h"

namespace {

using namespace evermap::sim;
using evermap::node_added_t;
using evermap::register_request_t;

SimOptions paperScale() {
  SimOptions o;  // defaults: 10 floors, 14 sessions
  o.patrol.total_hours = 7.3;
  o.patrol.drive_speed_mps = 0.45;
  o.patrol.pause_max_s = 25;
  o.building.blank_wall_fraction = 0.3;
  o.sensors.vo.rate_hz = 30;
  o.sensors.vo.keyframe_translation_m = 0.014;
  o.sensors.vo.passerby_rate_per_hour = 40;
  o.sensors.vo.passerby_max_s = 6;
  return o;
}

// Plans session 1 (about 35 simulated minutes).
void BM_PlanSession(benchmark::State& state) {
  const auto run = RunPlan::create(paperScale());
  for (auto _ : state) {
    const SessionPlan s = run->session(1);
    benchmark::DoNotOptimize(s.distance_m);
  }
}
BENCHMARK(BM_PlanSession)->Unit(benchmark::kMillisecond);

// Generates and encodes every message of session 1; counters give simulated seconds per
// wall-clock second and messages per second.
void BM_GenerateSession(benchmark::State& state) {
  const auto run = RunPlan::create(paperScale());
  const SessionPlan s = run->session(1);
  int64_t messages = 0;
  double simulated_s = 0.0;
  for (auto _ : state) {
    CountingSink counter;
    const SessionSummary summary =
        generateSession(run->building(), s, run->options().sensors, run->options().seed, counter);
    for (const auto& [name, c] : counter.counts()) messages += c.messages;
    simulated_s += summary.durationS();
  }
  state.SetItemsProcessed(messages);
  state.counters["sim_s_per_s"] = benchmark::Counter(simulated_s, benchmark::Counter::kIsRate);
}
BENCHMARK(BM_GenerateSession)->Unit(benchmark::kMillisecond);

// A map of 5000 nodes on one 90 m x 30 m floor (one node per metre and 45 degrees, as the
// reduced pose graph would hold), then requests alternating MODE_NODE and MODE_GLOBAL.
void BM_OracleAnswer(benchmark::State& state) {
  RegistrationOracle oracle(OracleOptions{}, 1);
  Random rng(2);
  const SE3d body_T_cam = CameraOptions{}.bodyTCam();
  auto keyframe = [&](int64_t utime) {
    const SE3d body(evermap::core::SO3d::fromRollPitchYaw(0, 0, rng.uniform(-3.14, 3.14)),
                    Vec3(rng.uniform(-45, 45), rng.uniform(-15, 15), 0.0));
    oracle.addKeyframe(KeyframeTruth{utime, body * body_T_cam, 0, 0});
  };
  for (int i = 0; i < 5000; ++i) {
    keyframe(i + 1);
    node_added_t n{};
    n.node_id = i;
    n.keyframe_utime = i + 1;
    oracle.addNode(n);
  }
  for (int i = 0; i < 1000; ++i) keyframe(100000 + i);
  int64_t k = 0;
  for (auto _ : state) {
    register_request_t r{};
    r.request_id = k;
    r.keyframe_utime = 100000 + (k % 1000);
    r.mode = (k % 2) ? register_request_t::MODE_GLOBAL : register_request_t::MODE_NODE;
    r.target_node_id = k % 5000;
    r.floor = 0;
    benchmark::DoNotOptimize(oracle.answer(r).status);
    ++k;
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_OracleAnswer);

}  // namespace

BENCHMARK_MAIN();
