// Image-level simulator: stereo pairs rendered per second on one thread (the bar:
// >= 100 pairs/s at 640x480), along the first minute of a patrol of config/sim-image-3floor.conf's
// building, with and without encoding the pair into its LCM message.
#include <benchmark/benchmark.h>

#include <cstdio>
#include <memory>

#include "core/common/key_value_file.h"
#include "core/messages/convert.h"
#include "tools/sim/image_session.h"

namespace {

using evermap::sim::ImageSimulator;

std::unique_ptr<ImageSimulator> makeSimulator(int width, int height) {
  const std::string text =
      "seed = 1\nbuilding.floors = 3\nbuilding.main_floor = 1\npatrol.sessions = 1\n"
      "patrol.total_hours = 0.05\nrender.width = " +
      std::to_string(width) + "\nrender.height = " + std::to_string(height) +
      "\ncamera.cx = " + std::to_string(width / 2) + "\ncamera.cy = " + std::to_string(height / 2) +
      "\n";
  auto file = evermap::KeyValueFile::parse(text, "bench");
  auto options = evermap::sim::loadImageSimOptions(*file);
  if (!options) {
    std::fprintf(stderr, "%s\n", options.error().message.c_str());
    std::abort();
  }
  const auto posters = evermap::sim::defaultPosterFolder(EVERMAP_DATA_DEFAULT);
  options->render.posters = posters.empty() ? "none" : posters.string();
  auto sim = ImageSimulator::create(*options);
  if (!sim) {
    std::fprintf(stderr, "%s\n", sim.error().message.c_str());
    std::abort();
  }
  return std::move(*sim);
}

void BM_RenderStereoPair(benchmark::State& state) {
  auto sim = makeSimulator(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  const int64_t start = sim->startUtime(),
                span = std::min<int64_t>(60'000'000, sim->endUtime() - start);
  cv::Mat left, right;
  int64_t k = 0;
  for (auto _ : state) {
    const int64_t t = start + (k++ * 50'000) % span;  // 20 Hz along the first minute
    sim->renderPair(t, &left, &right);
    benchmark::DoNotOptimize(left.data);
  }
  state.counters["pairs_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_RenderStereoPair)
    ->Args({640, 480})
    ->Args({752, 480})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

void BM_RenderAndEncodePng(benchmark::State& state) {
  auto sim = makeSimulator(640, 480);
  const int64_t start = sim->startUtime();
  cv::Mat left, right;
  int64_t k = 0;
  for (auto _ : state) {
    const int64_t t = start + (k++ * 50'000) % 60'000'000;
    sim->renderPair(t, &left, &right);
    auto msg = evermap::messages::toMsg(evermap::messages::StereoFrame{t, true, left, right},
                                        evermap::messages::ImageEncoding::kPng);
    benchmark::DoNotOptimize(msg);
  }
  state.counters["pairs_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_RenderAndEncodePng)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
