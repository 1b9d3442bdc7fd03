// The image encodings of core/messages/image_codec (issue 52): decode and encode time per image
// and bytes per image, for rendered frames (config/sim-image-3floor.conf's building, 752x480,
// its noise) and the real images under $EVERMAP_DATA (EuRoC V1_01 excerpt,
// KITTI stereo clip, TUM RGB-D fr1/rpy gray). Also the stereo pair's decode as fromMsg does it
// (right image on a second thread) against one image after the other.
//
//   build/bench/image_codec_bench [--benchmark_filter=Decode]
//
// Counters: bytes (per image, encoded), ratio_vs_png (bytes against PNG's on the same images).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "core/common/key_value_file.h"
#include "core/messages/convert.h"
#include "tools/sim/image_session.h"

namespace {

namespace fs = std::filesystem;
using evermap::messages::ImageEncoding;

constexpr int kImagesPerSet = 12;

fs::path dataRoot() {
  const char* env = std::getenv("EVERMAP_DATA");
  return env && *env ? fs::path(env) : fs::path(EVERMAP_DATA_DEFAULT);
}

// Rendered left and right images of config/sim-image-3floor.conf's session 0, every 10 s.
std::vector<cv::Mat> renderedImages() {
  auto file =
      evermap::KeyValueFile::load(fs::path(EVERMAP_SOURCE_DIR) / "config/sim-image-3floor.conf");
  if (!file) return {};
  auto options = evermap::sim::loadImageSimOptions(*file);
  if (!options) return {};
  const auto posters = evermap::sim::defaultPosterFolder(dataRoot());
  options->render.posters = posters.empty() ? "none" : posters.string();
  auto sim = evermap::sim::ImageSimulator::create(*options);
  if (!sim) return {};
  std::vector<cv::Mat> images;
  const int64_t start = (*sim)->startUtime();
  for (int k = 0; k < kImagesPerSet / 2; ++k) {
    cv::Mat left, right;
    (*sim)->renderPair(start + k * 10'000'000, &left, &right);
    images.push_back(left.clone());
    images.push_back(right.clone());
  }
  return images;
}

// Every n-th PNG of a folder, as gray images.
std::vector<cv::Mat> folderImages(const fs::path& dir) {
  std::vector<fs::path> files;
  if (!fs::is_directory(dir)) return {};
  for (const auto& e : fs::directory_iterator(dir)) files.push_back(e.path());
  std::sort(files.begin(), files.end());
  std::vector<cv::Mat> images;
  const size_t step = std::max<size_t>(1, files.size() / kImagesPerSet);
  for (size_t i = 0; i < files.size() && images.size() < kImagesPerSet; i += step) {
    cv::Mat m = cv::imread(files[i].string(), cv::IMREAD_GRAYSCALE);
    if (!m.empty()) images.push_back(m);
  }
  return images;
}

struct Set {
  std::string name;
  std::vector<cv::Mat> images;
  std::map<ImageEncoding, std::vector<evermap::image_t>> messages;
  double bytes(ImageEncoding e) const {
    double sum = 0;
    for (const auto& m : messages.at(e)) sum += static_cast<double>(m.data.size());
    return sum / static_cast<double>(messages.at(e).size());
  }
};

const std::vector<ImageEncoding> kEncodings = {ImageEncoding::kPng, ImageEncoding::kZstd,
                                               ImageEncoding::kGray8};

std::vector<std::unique_ptr<Set>> loadSets() {
  const fs::path d = dataRoot();
  std::vector<std::pair<std::string, std::vector<cv::Mat>>> raw = {
      {"rendered", renderedImages()},
      {"euroc", folderImages(d / "euroc-v101-micro/mav0/cam0/data")},
      {"kitti", folderImages(d / "kitti-stereo-clip/image_l")},
      {"tum", folderImages(d / "tum-rgbd-fr1-rpy/rgb")}};
  std::vector<std::unique_ptr<Set>> sets;
  for (auto& [name, images] : raw) {
    if (images.empty()) {
      std::fprintf(stderr, "image_codec_bench: no %s images, skipped\n", name.c_str());
      continue;
    }
    auto s = std::make_unique<Set>();
    s->name = name;
    s->images = std::move(images);
    for (ImageEncoding e : kEncodings) {
      for (const cv::Mat& m : s->images)
        s->messages[e].push_back(*evermap::messages::toMsg(m, 1, e));
    }
    sets.push_back(std::move(s));
  }
  return sets;
}

void counters(benchmark::State& state, const Set& s, ImageEncoding e) {
  state.counters["bytes"] = s.bytes(e);
  state.counters["ratio_vs_png"] = s.bytes(e) / s.bytes(ImageEncoding::kPng);
}

void decode(benchmark::State& state, const Set* s, ImageEncoding e) {
  const auto& msgs = s->messages.at(e);
  size_t k = 0;
  for (auto _ : state) {
    auto image = evermap::messages::fromMsg(msgs[k++ % msgs.size()]);
    benchmark::DoNotOptimize(image);
  }
  counters(state, *s, e);
}

void encode(benchmark::State& state, const Set* s, ImageEncoding e) {
  size_t k = 0;
  for (auto _ : state) {
    auto msg = evermap::messages::toMsg(s->images[k++ % s->images.size()], 1, e);
    benchmark::DoNotOptimize(msg);
  }
  counters(state, *s, e);
}

// A stereo pair: fromMsg (right on a second thread) or the two images one after the other.
void decodePair(benchmark::State& state, const Set* s, ImageEncoding e, bool parallel) {
  const auto& msgs = s->messages.at(e);
  evermap::stereo_image_t pair;
  pair.left = msgs[0];
  pair.right = msgs[1];
  for (auto _ : state) {
    if (parallel) {
      auto frame = evermap::messages::fromMsg(pair);
      benchmark::DoNotOptimize(frame);
    } else {
      auto l = evermap::messages::fromMsg(pair.left);
      auto r = evermap::messages::fromMsg(pair.right);
      benchmark::DoNotOptimize(l);
      benchmark::DoNotOptimize(r);
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  const auto sets = loadSets();
  for (const auto& s : sets) {
    for (ImageEncoding e : kEncodings) {
      const std::string tag = s->name + "/" + evermap::messages::toString(e);
      benchmark::RegisterBenchmark(("Decode/" + tag).c_str(), decode, s.get(), e)
          ->Unit(benchmark::kMillisecond);
      benchmark::RegisterBenchmark(("Encode/" + tag).c_str(), encode, s.get(), e)
          ->Unit(benchmark::kMillisecond);
    }
  }
  if (!sets.empty() && sets[0]->name == "rendered") {
    for (ImageEncoding e : {ImageEncoding::kPng, ImageEncoding::kZstd}) {
      for (bool parallel : {false, true}) {
        const std::string name = std::string("DecodeStereoPair/rendered/") +
                                 evermap::messages::toString(e) +
                                 (parallel ? "/parallel" : "/serial");
        benchmark::RegisterBenchmark(name.c_str(), decodePair, sets[0].get(), e, parallel)
            ->Unit(benchmark::kMillisecond)
            ->UseRealTime();
      }
    }
  }
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
