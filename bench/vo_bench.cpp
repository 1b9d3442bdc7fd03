// Cost of visual odometry per 752x480 stereo frame on one thread (OpenCV's own threads off),
// timed as the thread's CPU time (the machine may be shared),
// on the real EuRoC excerpt (95 frames, rectified once beforehand), and of its stages:
//  - BM_VoFrame: StereoOdometry::process on rectified pairs, frame after frame; prints the
//    median and p99 over all processed frames and the peak resident memory of the process.
//  - BM_VoFrameWithRectify: the same plus rectifying the raw pair (what vo-proc pays on raw
//    EuRoC input).
//  - BM_FeatureExtraction: pyramid, FAST, stereo depth, patches of one frame.
//  - BM_RegisterKeyframes: registerFrames() of two keyframes (what loop closure pays).
//  - BM_VoKittiClip: the real KITTI clip with ~1 m between frames: frames tracked, inliers,
//    median/p90/p99 ms per frame (thread CPU, PNG decoding excluded), end drift, ATE, RPE.
// Without the data set the benchmarks are skipped with a message.
#include <benchmark/benchmark.h>

#include <sys/resource.h>
#include <time.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "bench/loaded_inputs.h"
#include "core/camera/stereo_rectifier.h"
#include "core/common/clocks.h"
#include "core/registration/frame_registration.h"
#include "tools/datasets/euroc.h"
#include "tools/datasets/euroc_calibration.h"
#include "tools/vo-run/sequence_run.h"
#include "vo-proc/stereo_odometry.h"

namespace {

namespace fs = std::filesystem;
using namespace evermap;

struct Inputs {
  std::optional<core::StereoRectifier> rectifier;
  std::vector<cv::Mat> raw_left, raw_right, left, right;
  std::string error;
};

const Inputs& inputs() {
  static const Inputs in = [] {
    cv::setNumThreads(1);  // one thread: OpenCV would parallelise remap and pyrDown
    Inputs r;
    const char* env = std::getenv("EVERMAP_DATA");
    const fs::path dir =
        (env && *env ? fs::path(env) : fs::path(EVERMAP_DATA_DEFAULT)) / "euroc-v101-micro";
    auto calib = datasets::readEurocStereoCalibration(dir / "mav0/cam0/sensor.yaml",
                                                      dir / "mav0/cam1/sensor.yaml");
    auto images = datasets::readEurocImages(dir / "mav0/cam0/data.csv");
    if (!calib || !images) {
      r.error = "EuRoC excerpt not found under " + dir.string();
      return r;
    }
    auto rect = core::StereoRectifier::create(*calib);
    if (!rect) {
      r.error = rect.error().message;
      return r;
    }
    r.rectifier.emplace(std::move(*rect));
    for (const auto& e : *images) {
      const std::string name = std::to_string(e.t_ns) + ".png";
      cv::Mat L = cv::imread((dir / "mav0/cam0/data" / name).string(), cv::IMREAD_GRAYSCALE);
      cv::Mat R = cv::imread((dir / "mav0/cam1/data" / name).string(), cv::IMREAD_GRAYSCALE);
      if (L.empty() || R.empty()) continue;
      auto pair = r.rectifier->rectify(L, R);
      r.raw_left.push_back(L);
      r.raw_right.push_back(R);
      r.left.push_back(pair->left);
      r.right.push_back(pair->right);
    }
    if (r.left.empty()) r.error = "no EuRoC images could be read";
    return r;
  }();
  return in;
}

double peakRssMb() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_maxrss) / 1024.0;  // kilobytes on Linux
}

void report(benchmark::State& state, std::vector<double> ms) {
  std::sort(ms.begin(), ms.end());
  state.counters["median_ms"] = ms[ms.size() / 2];
  state.counters["p90_ms"] = ms[ms.size() * 9 / 10];
  state.counters["p99_ms"] = ms[std::min(ms.size() - 1, ms.size() * 99 / 100)];
  state.counters["peak_rss_MB"] = peakRssMb();
  size_t bytes = 0;
  for (const auto* v : {&inputs().raw_left, &inputs().raw_right, &inputs().left, &inputs().right}) {
    for (const cv::Mat& m : *v) bytes += m.total();
  }
  state.counters["images_held_MB"] = static_cast<double>(bytes) / (1024.0 * 1024.0);
}

// Frames go through in order; at the end of the excerpt odometry restarts (a first frame is
// cheap: it is timed like the others, 1 in 95).
void runVo(benchmark::State& state, bool rectify) {
  const Inputs* loaded = loadedInputs(state, inputs());
  if (!loaded) return;
  const Inputs& in = *loaded;
  auto vo = vo::StereoOdometry::create(in.rectifier->camera(), vo::OdometryOptions{});
  std::vector<double> ms;
  size_t k = 0;
  int64_t utime = 0;
  int failures = 0;
  for (auto _ : state) {
    if (k == in.left.size()) {
      k = 0;
      vo->reset();
    }
    const double start = 1e3 * threadCpuSeconds();
    vo::FrameResult r;
    if (rectify) {
      auto pair = in.rectifier->rectify(in.raw_left[k], in.raw_right[k]);
      r = vo->process(utime += 50000, pair->left, pair->right);
    } else {
      r = vo->process(utime += 50000, in.left[k], in.right[k]);
    }
    const double t = 1e3 * threadCpuSeconds() - start;
    state.SetIterationTime(t / 1000.0);
    ms.push_back(t);
    if (r.status != vo::VoStatus::kOk && r.status != vo::VoStatus::kNoData) ++failures;
    ++k;
  }
  report(state, ms);
  state.counters["failed_frames"] = failures;
}

void BM_VoFrame(benchmark::State& state) { runVo(state, false); }
BENCHMARK(BM_VoFrame)->UseManualTime()->Unit(benchmark::kMillisecond)->Iterations(475);

void BM_VoFrameWithRectify(benchmark::State& state) { runVo(state, true); }
BENCHMARK(BM_VoFrameWithRectify)->UseManualTime()->Unit(benchmark::kMillisecond)->Iterations(285);

void BM_FeatureExtraction(benchmark::State& state) {
  const Inputs* loaded = loadedInputs(state, inputs());
  if (!loaded) return;
  const Inputs& in = *loaded;
  auto extractor = core::StereoFeatureExtractor::create(vo::OdometryOptions{}.features);
  core::FeatureFrame frame;
  size_t k = 0;
  for (auto _ : state) {
    (void)extractor->extract(in.rectifier->camera(), 0, in.left[k], in.right[k], &frame);
    k = (k + 1) % in.left.size();
  }
  state.counters["features"] = static_cast<double>(frame.features.size());
  state.counters["corners"] = frame.num_corners;
}
BENCHMARK(BM_FeatureExtraction)->Unit(benchmark::kMillisecond);

void BM_RegisterKeyframes(benchmark::State& state) {
  const Inputs* loaded = loadedInputs(state, inputs());
  if (!loaded) return;
  const Inputs& in = *loaded;
  auto extractor = core::StereoFeatureExtractor::create(vo::OdometryOptions{}.features);
  core::OrbExtractor orb(core::OrbExtractor::Options{});
  core::FeatureFrame a, b;
  (void)extractor->extract(in.rectifier->camera(), 0, in.left.front(), in.right.front(), &a);
  (void)extractor->extract(in.rectifier->camera(), 1, in.left.back(), in.right.back(), &b);
  const core::KeyframeFeatures ka = core::makeKeyframeFeatures(a, orb);
  const core::KeyframeFeatures kb = core::makeKeyframeFeatures(b, orb);
  core::RegistrationSummary s;
  for (auto _ : state) {
    s = core::registerFrames(in.rectifier->camera(), ka, in.rectifier->camera(), kb,
                             core::RegistrationOptions{});
    benchmark::DoNotOptimize(s);
  }
  state.counters["features"] = static_cast<double>(ka.size());
  state.counters["inliers"] = s.num_inliers;
}
BENCHMARK(BM_RegisterKeyframes)->Unit(benchmark::kMillisecond);

// The whole kitti-stereo-clip (51 rectified 1241x376 pairs, ~1 m apart, a turn) per
// iteration, straight from its folder: inliers, time per frame (thread CPU) and the error at
// the end against KITTI's ground truth (tools/vo-run/sequence_run.h).
void BM_VoKittiClip(benchmark::State& state) {
  const char* env = std::getenv("EVERMAP_DATA");
  const fs::path dir =
      (env && *env ? fs::path(env) : fs::path(EVERMAP_DATA_DEFAULT)) / "kitti-stereo-clip";
  if (!fs::exists(dir)) {
    state.SkipWithError(("KITTI clip not found under " + dir.string()).c_str());
    return;
  }
  cv::setNumThreads(1);
  vo::SequenceRunOptions options;
  options.sequence.rate_hz = 10.0;
  Expected<vo::SequenceRun> run = Error{""};
  for (auto _ : state) {
    run = vo::runKittiSequence(dir, options);
    if (!run) {
      state.SkipWithError(run.error().message.c_str());
      return;
    }
  }
  int tracked = 0;
  for (const vo::FrameResult& f : run->frames) {
    tracked += (f.ok() && !f.bridged) || f.status == vo::VoStatus::kNoData ? 1 : 0;
  }
  state.counters["frames"] = static_cast<double>(run->frames.size());
  state.counters["tracked"] = tracked;
  state.counters["keyframes"] = run->keyframes;
  state.counters["inliers"] = run->mean_inliers;
  state.counters["median_ms"] = run->median_ms;
  state.counters["p90_ms"] = run->p90_ms;
  state.counters["p99_ms"] = run->p99_ms;
  state.counters["end_pct"] = run->end_error_percent;
  state.counters["end_deg"] = run->end_rotation_deg;
  state.counters["ate_m"] = run->ate_rmse_m;
  state.counters["rpe_pct"] = run->rpe_percent;
  state.counters["rpe_deg"] = run->rpe_deg;
  std::printf("%s\n", run->report().c_str());
}
BENCHMARK(BM_VoKittiClip)->Unit(benchmark::kMillisecond)->Iterations(3);

}  // namespace

BENCHMARK_MAIN();
