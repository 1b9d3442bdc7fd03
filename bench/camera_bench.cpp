// Cost of the per-frame camera and message work: rectifying a raw EuRoC pair, encoding and
// decoding a stereo message (PNG and raw), and the back-projection covariance of one point.
// Uses the real EuRoC excerpt when $EVERMAP_DATA (or ../shared/data) has it, else images of
// noise of the same size (noise compresses worse than real images: PNG figures are then
// pessimistic).
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <filesystem>
#include <random>

#include <opencv2/imgcodecs.hpp>

#include "core/camera/stereo_rectifier.h"
#include "core/messages/convert.h"
#include "tools/datasets/euroc_calibration.h"

namespace {

namespace fs = std::filesystem;
using namespace evermap;

fs::path eurocDir() {
  const char* env = std::getenv("EVERMAP_DATA");
  const fs::path root = env && *env ? fs::path(env) : fs::path(EVERMAP_DATA_DEFAULT);
  return root / "euroc-v101-micro";
}

struct Inputs {
  core::StereoCalibration calibration;
  cv::Mat left, right;
};

const Inputs& inputs() {
  static const Inputs in = [] {
    Inputs r;
    const fs::path dir = eurocDir();
    auto c = datasets::readEurocStereoCalibration(dir / "mav0/cam0/sensor.yaml",
                                                  dir / "mav0/cam1/sensor.yaml");
    if (c.ok()) {
      r.calibration = *c;
      r.left = cv::imread((dir / "mav0/cam0/data/1403715273262142976.png").string(),
                          cv::IMREAD_UNCHANGED);
      r.right = cv::imread((dir / "mav0/cam1/data/1403715273262142976.png").string(),
                           cv::IMREAD_UNCHANGED);
    }
    if (r.left.empty() || r.right.empty()) {
      std::fprintf(stderr, "camera_bench: EuRoC excerpt not found, using noise images\n");
      for (core::CameraCalibration* cam : {&r.calibration.left, &r.calibration.right}) {
        cam->width = 752;
        cam->height = 480;
        cam->fx = cam->fy = 458.0;
        cam->cx = 367.0;
        cam->cy = 248.0;
        cam->distortion_model = core::DistortionModel::kRadTan;
        cam->distortion = {-0.28, 0.07, 0.0002, 0.00002};
      }
      r.calibration.right.body_T_cam = core::SE3d(core::SO3d(), core::Vec3(0.11, 0.0, 0.0));
      r.left = cv::Mat(480, 752, CV_8UC1);
      r.right = cv::Mat(480, 752, CV_8UC1);
      cv::randu(r.left, 0, 255);
      cv::randu(r.right, 0, 255);
    }
    return r;
  }();
  return in;
}

void BM_RectifierCreate(benchmark::State& state) {
  for (auto _ : state) {
    auto r = core::StereoRectifier::create(inputs().calibration);
    benchmark::DoNotOptimize(r);
  }
}
BENCHMARK(BM_RectifierCreate)->Unit(benchmark::kMillisecond);

void BM_RectifyPair752x480(benchmark::State& state) {
  const auto rect = core::StereoRectifier::create(inputs().calibration);
  if (!rect) {
    state.SkipWithError(rect.error().message.c_str());
    return;
  }
  for (auto _ : state) {
    auto pair = rect->rectify(inputs().left, inputs().right);
    benchmark::DoNotOptimize(pair);
  }
}
BENCHMARK(BM_RectifyPair752x480)->Unit(benchmark::kMillisecond);

// Gray8 (range 0) and PNG (range 1), milliseconds.
void eachEncoding(benchmark::internal::Benchmark* b) {
  b->Arg(static_cast<int>(messages::ImageEncoding::kGray8))
      ->Arg(static_cast<int>(messages::ImageEncoding::kPng))
      ->Unit(benchmark::kMillisecond);
}

void BM_StereoMsgEncode(benchmark::State& state) {
  const auto enc = static_cast<messages::ImageEncoding>(state.range(0));
  messages::StereoFrame f{1, false, inputs().left, inputs().right};
  int64_t bytes = 0;
  for (auto _ : state) {
    auto msg = messages::toMsg(f, enc);
    bytes = msg->getEncodedSize();
    benchmark::DoNotOptimize(msg);
  }
  state.counters["msg_bytes"] = static_cast<double>(bytes);
  state.SetLabel(messages::toString(enc));
}
BENCHMARK(BM_StereoMsgEncode)->Apply(eachEncoding);

// What a receiver pays per STEREO message: bytes -> validated message -> two cv::Mat.
void BM_StereoMsgDecodeAndValidate(benchmark::State& state) {
  const auto enc = static_cast<messages::ImageEncoding>(state.range(0));
  const auto msg =
      *messages::toMsg(messages::StereoFrame{1, false, inputs().left, inputs().right}, enc);
  std::vector<uint8_t> bytes(msg.getEncodedSize());
  msg.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  for (auto _ : state) {
    auto m = messages::decodeLcm<evermap::stereo_image_t>(bytes.data(),
                                                          static_cast<int64_t>(bytes.size()), "B");
    auto frame = messages::fromMsg(*m);
    benchmark::DoNotOptimize(frame);
  }
  state.SetLabel(messages::toString(enc));
}
BENCHMARK(BM_StereoMsgDecodeAndValidate)->Apply(eachEncoding);

void BM_BackProjectionCovariance(benchmark::State& state) {
  const auto cam = *core::StereoCamera::create(436.2, 436.2, 364.4, 257.0, 0.110, 752, 480);
  Eigen::Vector3d uvd(400.0, 200.0, 12.5);
  for (auto _ : state) {
    benchmark::DoNotOptimize(cam.backProjectionCovariance(uvd, 0.5, 0.3));
    uvd.x() += 1e-9;
  }
}
BENCHMARK(BM_BackProjectionCovariance);

}  // namespace

BENCHMARK_MAIN();
