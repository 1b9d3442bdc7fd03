// tools/eval speed on the real files: reading, association, Umeyama, the whole evaluation,
// KITTI drift on the longest sequence, and the top-view figure.
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <filesystem>
#include <utility>

#include "tools/eval/evaluation.h"
#include "tools/eval/plot.h"

namespace {

using namespace evermap::eval;
namespace fs = std::filesystem;

fs::path data() {
  const char* env = std::getenv("EVERMAP_DATA");
  return env && *env ? fs::path(env) : fs::path(EVERMAP_DATA_DEFAULT);
}
const fs::path kEuroc = data() / "euroc-v101-micro/groundtruth_openvins";
const fs::path kKitti = data() / "kitti-gt-poses";

// 28 712 poses at 200 Hz.
void BM_ReadTum(benchmark::State& state) {
  for (auto _ : state) {
    auto t = readTum(kEuroc / "V1_01_easy_original.txt");
    if (!t) {
      state.SkipWithError(t.error().message.c_str());
      return;
    }
    benchmark::DoNotOptimize(t->poses.data());
  }
  state.SetItemsProcessed(state.iterations() * 28712);
}
BENCHMARK(BM_ReadTum)->Unit(benchmark::kMillisecond);

// The OpenVINS ground truth of V1_01 (the original, 28 712 poses) and its 2 895-pose
// version; false (the benchmark skipped) when they are missing.
bool readEurocPair(benchmark::State& state, Trajectory* gt, Trajectory* est) {
  auto a = readTum(kEuroc / "V1_01_easy_original.txt");
  auto b = readEuroc(kEuroc / "V1_01_easy.csv");
  if (!a || !b) {
    state.SkipWithError("EuRoC ground truth missing");
    return false;
  }
  *gt = std::move(*a);
  *est = std::move(*b);
  return true;
}

// The whole evaluation (association, SE(3) alignment, ATE, RPE) of the 2 895-pose OpenVINS
// ground truth against the 28 712-pose original.
void BM_EvaluateEuroc(benchmark::State& state) {
  Trajectory gt, est;
  if (!readEurocPair(state, &gt, &est)) return;
  for (auto _ : state) {
    auto r = evaluate(gt, est, {});
    benchmark::DoNotOptimize(r.ok());
  }
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(est.size()));
}
BENCHMARK(BM_EvaluateEuroc)->Unit(benchmark::kMillisecond);

// KITTI 00 (4 541 poses, 3.7 km) with Sim(3) alignment, RPE over 100 m and the drift.
void BM_EvaluateKitti00WithDrift(benchmark::State& state) {
  const auto gt = readKitti(kKitti / "00.txt");
  if (!gt) {
    state.SkipWithError(gt.error().message.c_str());
    return;
  }
  Trajectory est = *gt;
  for (size_t k = 0; k < est.size(); ++k) {
    auto& T = est.poses[k].world_T_body;
    T = evermap::core::SE3d(T.so3(), 1.01 * T.translation());
  }
  EvaluationOptions options;
  options.alignment = AlignmentMode::kSim3;
  options.rpe = {.delta_frames = 0, .delta_distance_m = 100.0};
  options.kitti_drift = true;
  for (auto _ : state) {
    auto r = evaluate(*gt, est, options);
    benchmark::DoNotOptimize(r.ok());
  }
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(gt->size()));
}
BENCHMARK(BM_EvaluateKitti00WithDrift)->Unit(benchmark::kMillisecond);

// Drawing and encoding the 28 712 + 2 895 positions, PNG (range 0) or SVG (range 1).
void BM_TopView(benchmark::State& state) {
  Trajectory gt, est;
  if (!readEurocPair(state, &gt, &est)) return;
  std::vector<evermap::core::Vec3> a, b;
  for (const auto& p : gt.poses) a.push_back(p.world_T_body.translation());
  for (const auto& p : est.poses) b.push_back(p.world_T_body.translation());
  for (auto _ : state) {
    auto c = drawTopView(a, b, {});
    if (state.range(0) == 0) {
      benchmark::DoNotOptimize(c->encodePng().ok());
    } else {
      benchmark::DoNotOptimize(c->encodeSvg().size());
    }
  }
}
BENCHMARK(BM_TopView)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
