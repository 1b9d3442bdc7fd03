// evermap-vo-proc: stereo visual odometry on LCM. Subscribes to STEREO_CALIB and STEREO,
// publishes VO_DELTA per frame and KEYFRAME per new keyframe (vo-proc/vo_pipeline.h).
//
// Threads: the LCM thread only copies each received STEREO event into a bounded queue
// (dropping the oldest when the worker falls behind) and keeps the latest calibration; the
// worker thread decodes, runs odometry and publishes (lcm::LCM::publish is thread-safe).
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "core/common/stop_signals.h"
#include "core/messages/channels.h"
#include "vo-proc/frame_queue.h"
#include "vo-proc/vo_pipeline.h"

namespace {

constexpr const char* kUsage =
    "usage: evermap-vo-proc [--lcm-url URL] [--queue N] [--no-descriptors]\n"
    "                       [--keyframe-inliers N] [--ready-file PATH] [--print-options]\n"
    "  --lcm-url URL          LCM provider (default: $LCM_DEFAULT_URL or LCM's default)\n"
    "  --queue N              frames waiting at most (default 2); older ones are dropped\n"
    "  --no-descriptors       keyframes without ORB descriptors (faster; no loop closure)\n"
    "  --keyframe-inliers N   new keyframe below N inliers (default 150)\n"
    "  --ready-file PATH      create PATH once subscribed (for scripts)\n"
    "  --print-options        print the odometry options and exit\n";

using Bytes = std::vector<uint8_t>;

struct Shared {
  std::mutex mutex;
  std::optional<Bytes> calibration;  // the latest STEREO_CALIB, not yet applied
};

class Receiver {
 public:
  Receiver(evermap::vo::BoundedQueue<Bytes>* queue, Shared* shared)
      : queue_(queue), shared_(shared) {}
  void onStereo(const lcm::ReceiveBuffer* rbuf, const std::string&) {
    const auto* p = static_cast<const uint8_t*>(rbuf->data);
    queue_->push(Bytes(p, p + rbuf->data_size));
  }
  void onCalibration(const lcm::ReceiveBuffer* rbuf, const std::string&) {
    const auto* p = static_cast<const uint8_t*>(rbuf->data);
    std::lock_guard<std::mutex> lock(shared_->mutex);
    shared_->calibration = Bytes(p, p + rbuf->data_size);
  }

 private:
  evermap::vo::BoundedQueue<Bytes>* queue_;
  Shared* shared_;
};

}  // namespace

int main(int argc, char** argv) {
  std::string url;
  size_t queue_size = 2;
  evermap::vo::PipelineOptions options;
  bool print_options = false;
  std::string ready_file;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--lcm-url" && i + 1 < argc) {
      url = argv[++i];
    } else if (a == "--queue" && i + 1 < argc) {
      queue_size = static_cast<size_t>(std::max(1, std::atoi(argv[++i])));
    } else if (a == "--no-descriptors") {
      options.odometry.keyframe_descriptors = false;
    } else if (a == "--keyframe-inliers" && i + 1 < argc) {
      options.odometry.keyframe_inlier_threshold = std::atoi(argv[++i]);
    } else if (a == "--ready-file" && i + 1 < argc) {
      ready_file = argv[++i];
    } else if (a == "--print-options") {
      print_options = true;
    } else if (a == "-h" || a == "--help") {
      std::fputs(kUsage, stdout);
      return 0;
    } else {
      std::fprintf(stderr, "evermap-vo-proc: unknown argument %s\n%s", a.c_str(), kUsage);
      return 2;
    }
  }
  auto pipeline = evermap::vo::VoPipeline::create(options);
  if (!pipeline) {
    std::fprintf(stderr, "evermap-vo-proc: %s\n", pipeline.error().message.c_str());
    return 2;
  }
  if (print_options) {
    std::printf("%s\n", options.odometry.describe().c_str());
    return 0;
  }
  lcm::LCM lcm(url);
  if (!lcm.good()) {
    std::fprintf(stderr, "evermap-vo-proc: cannot open LCM (%s)\n",
                 url.empty() ? "default URL" : url.c_str());
    return 1;
  }
  evermap::StopSignals stop;  // SIGINT/SIGTERM; blocked before the worker starts, so it inherits that

  evermap::vo::BoundedQueue<Bytes> queue(queue_size);
  Shared shared;
  Receiver receiver(&queue, &shared);
  lcm.subscribe(evermap::channels::kStereo, &Receiver::onStereo, &receiver);
  lcm.subscribe(evermap::channels::kStereoCalib, &Receiver::onCalibration, &receiver);

  if (!ready_file.empty()) {
    if (std::FILE* f = std::fopen(ready_file.c_str(), "w")) std::fclose(f);
  }

  std::thread worker([&] {
    while (auto bytes = queue.pop()) {
      std::optional<Bytes> calibration;
      {
        std::lock_guard<std::mutex> lock(shared.mutex);
        calibration.swap(shared.calibration);
      }
      if (calibration) {
        if (evermap::Status s = pipeline->handleCalibrationBytes(
                calibration->data(), static_cast<int64_t>(calibration->size()));
            !s) {
          std::fprintf(stderr, "evermap-vo-proc: %s\n", s.error().message.c_str());
        }
      }
      auto out = pipeline->handleStereoBytes(bytes->data(), static_cast<int64_t>(bytes->size()));
      if (!out) {
        std::fprintf(stderr, "evermap-vo-proc: dropped: %s\n", out.error().message.c_str());
        continue;
      }
      if (out->result.status != evermap::vo::VoStatus::kOk) {
        std::fprintf(stderr, "evermap-vo-proc: %lld %s: %s\n",
                     static_cast<long long>(out->result.utime),
                     evermap::vo::toString(out->result.status), out->result.message.c_str());
      }
      lcm.publish(evermap::channels::kVoDelta, &out->delta);
      if (out->keyframe) lcm.publish(evermap::channels::kKeyframe, &*out->keyframe);
    }
  });

  while (!stop.requested()) lcm.handleTimeout(200);
  queue.close();
  worker.join();
  std::fprintf(stderr, "evermap-vo-proc: %s; %lld frames dropped behind (queue %zu)\n",
               pipeline->stats().report().c_str(), static_cast<long long>(queue.dropped()),
               queue_size);
  return 0;
}
