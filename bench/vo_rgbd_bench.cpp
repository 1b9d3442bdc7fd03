// Cost of RGB-D visual odometry per 640x480 Kinect frame on one thread (OpenCV's own threads
// off), timed as the thread's CPU time (the machine may be shared), on the real TUM
// freiburg1_rpy excerpt (150 frames, PNGs decoded beforehand):
//  - BM_RgbdVoFrame: VoPipeline::handleRgbdFrame (undistortion of gray and depth, features
//    with depth from the depth image, matching, registration), frame after frame; the
//    pipeline restarts at the end of the excerpt. Prints median and p99 ms, failed frames.
//  - BM_RgbdFeatureExtraction: pyramid, FAST, depth lookup, patches of one undistorted frame.
// Without the data set the benchmarks are skipped with a message.
#include <benchmark/benchmark.h>

#include <time.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "bench/loaded_inputs.h"
#include "core/camera/rgbd_camera.h"
#include "core/common/clocks.h"
#include "core/features/stereo_features.h"
#include "tools/datasets/tum_rgbd.h"
#include "vo-proc/vo_pipeline.h"

namespace {

namespace fs = std::filesystem;
using namespace evermap;

struct Inputs {
  std::vector<messages::RgbdFrame> frames;
  std::string error;
};

const Inputs& inputs() {
  static const Inputs in = [] {
    cv::setNumThreads(1);
    Inputs r;
    const char* env = std::getenv("EVERMAP_DATA");
    const fs::path dir =
        (env && *env ? fs::path(env) : fs::path(EVERMAP_DATA_DEFAULT)) / "tum-rgbd-fr1-rpy";
    auto seq = datasets::readTumRgbdSequence(dir);
    auto camera = datasets::tumCalibration("freiburg1");
    if (!seq || !camera) {
      r.error = "TUM RGB-D excerpt not found under " + dir.string();
      return r;
    }
    for (const auto& [c, d] : seq->frames) {
      messages::RgbdFrame f;
      f.utime = seq->color[c].t_ns / 1000;
      f.depth_utime = seq->depth[d].t_ns / 1000;
      f.gray = cv::imread((dir / seq->color[c].file).string(), cv::IMREAD_GRAYSCALE);
      f.depth = cv::imread((dir / seq->depth[d].file).string(), cv::IMREAD_UNCHANGED);
      f.camera = *camera;
      r.frames.push_back(std::move(f));
    }
    return r;
  }();
  return in;
}

void report(benchmark::State& state, std::vector<double> ms) {
  std::sort(ms.begin(), ms.end());
  state.counters["median_ms"] = ms[ms.size() / 2];
  state.counters["p90_ms"] = ms[ms.size() * 9 / 10];
  state.counters["p99_ms"] = ms[std::min(ms.size() - 1, ms.size() * 99 / 100)];
}

void BM_RgbdVoFrame(benchmark::State& state) {
  const Inputs* loaded = loadedInputs(state, inputs());
  if (!loaded) return;
  const Inputs& in = *loaded;
  std::optional<vo::VoPipeline> pipeline;
  std::vector<double> ms;
  size_t k = 0;
  int failures = 0;
  for (auto _ : state) {
    if (k == in.frames.size()) k = 0;
    if (k == 0) {
      auto p = vo::VoPipeline::create({});
      pipeline.emplace(std::move(*p));
    }
    const messages::RgbdFrame& f = in.frames[k];
    const double start = 1e3 * threadCpuSeconds();
    const vo::PipelineOutput out = pipeline->handleRgbdFrame(f.utime, f).back();
    const double t = 1e3 * threadCpuSeconds() - start;
    state.SetIterationTime(t / 1000.0);
    ms.push_back(t);
    if (out.result.status != vo::VoStatus::kOk && out.result.status != vo::VoStatus::kNoData) {
      ++failures;
    }
    ++k;
  }
  report(state, ms);
  state.counters["failed_frames"] = failures;
}
BENCHMARK(BM_RgbdVoFrame)->UseManualTime()->Unit(benchmark::kMillisecond)->Iterations(300);

void BM_RgbdFeatureExtraction(benchmark::State& state) {
  const Inputs* loaded = loadedInputs(state, inputs());
  if (!loaded) return;
  const Inputs& in = *loaded;
  auto camera = core::RgbdCamera::create(in.frames.front().camera, {});
  cv::Mat gray, depth;
  (void)camera->undistort(in.frames[10].gray, in.frames[10].depth, &gray, &depth);
  auto extractor = core::StereoFeatureExtractor::create(vo::OdometryOptions::defaultFeatures());
  core::FeatureFrame frame;
  for (auto _ : state) {
    (void)extractor->extractRgbd(camera->stereo(), 0, gray, depth, 0.0002, &frame);
  }
  state.counters["features"] = static_cast<double>(frame.features.size());
  state.counters["corners"] = frame.num_corners;
}
BENCHMARK(BM_RgbdFeatureExtraction)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
