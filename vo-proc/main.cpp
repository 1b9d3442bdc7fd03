// evermap-vo-proc: visual odometry on LCM. Subscribes to STEREO_CALIB and STEREO (a stereo
// rig) and RGBD (an RGB-D camera, its calibration inside), publishes VO_DELTA per frame and
// KEYFRAME per new keyframe (vo-proc/vo_pipeline.h); the outputs do not say which camera.
// Keeps its recent keyframes and publishes the parts of one again (KEYFRAME_PART) when a
// receiver that missed them asks on KEYFRAME_REQUEST (vo-proc/keyframe_buffer.h), at a bounded
// rate.
//
// Threads: the LCM thread only copies each received STEREO or RGBD event into a bounded queue
// (dropping the oldest when the worker falls behind) and keeps the latest calibration; the
// worker thread decodes (a stereo pair's two images in parallel: messages::fromMsg), runs
// odometry and publishes (lcm::LCM::publish is thread-safe).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "core/common/command_line.h"
#include "core/common/stop_signals.h"
#include "core/messages/channels.h"
#include "core/messages/inbox.h"
#include "core/messages/key_option.h"
#include "core/messages/outbox.h"
#include "core/messages/wire_check.h"
#include "vo-proc/frame_queue.h"
#include "vo-proc/keyframe_buffer.h"
#include "vo-proc/vo_pipeline.h"

namespace {

using Bytes = std::vector<uint8_t>;

struct QueuedFrame {
  bool rgbd = false;  // RGBD, else STEREO
  Bytes bytes;
};

struct Shared {
  std::mutex mutex;
  std::optional<Bytes> calibration;  // the latest STEREO_CALIB, not yet applied
};

// KEYFRAME is published by the worker (new keyframes), KEYFRAME_PART by the LCM thread (parts
// of keyframes asked for again): one mutex over the resender and both publishes keeps each
// channel's messages in the envelope's counter order (a receiver with a key refuses one out
// of order).
class KeyframeChannel {
 public:
  KeyframeChannel(const evermap::vo::KeyframeResendOptions& options,
                  const evermap::messages::Outbox* outbox)
      : resender_(options), outbox_(outbox) {}
  void publishNew(const evermap::keyframe_t& keyframe) {
    std::lock_guard<std::mutex> lock(mutex_);
    outbox_->publish(evermap::channels::kKeyframe, keyframe);
    resender_.keep(keyframe);
  }
  evermap::Status onRequest(const evermap::keyframe_request_t& request) {
    const double now_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
    std::lock_guard<std::mutex> lock(mutex_);
    for (const evermap::keyframe_part_t& part : resender_.answer(request, now_s)) {
      outbox_->publish(evermap::channels::kKeyframePart, part);
    }
    return evermap::Ok{};
  }
  std::string report() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return resender_.stats().text();
  }

 private:
  mutable std::mutex mutex_;
  evermap::vo::KeyframeResender resender_;
  const evermap::messages::Outbox* outbox_;
};

// The bytes come through a messages::Inbox: checked along their type's wire layout and by the
// time guard before they are queued; the worker decodes them (decodeLcm) and validates.
class Receiver {
 public:
  Receiver(evermap::vo::BoundedQueue<QueuedFrame>* queue, Shared* shared)
      : queue_(queue), shared_(shared) {}
  evermap::Status onFrame(bool rgbd, const void* data, int64_t size) {
    const auto* p = static_cast<const uint8_t*>(data);
    std::optional<QueuedFrame> dropped;
    queue_->push(QueuedFrame{rgbd, Bytes(p, p + size)}, &dropped);
    if (dropped) {
      // One line per frame lost, its time first: evermap-slam-run --drop-utimes replays them.
      const auto utime = evermap::messages::leadingUtime(
          dropped->bytes.data(), static_cast<int64_t>(dropped->bytes.size()));
      std::fprintf(stderr, "evermap-vo-proc: dropped behind the queue: frame %lld\n",
                   static_cast<long long>(utime.value_or(-1)));
    }
    return evermap::Ok{};
  }
  evermap::Status onCalibration(const void* data, int64_t size) {
    const auto* p = static_cast<const uint8_t*>(data);
    std::lock_guard<std::mutex> lock(shared_->mutex);
    shared_->calibration = Bytes(p, p + size);
    return evermap::Ok{};
  }

 private:
  evermap::vo::BoundedQueue<QueuedFrame>* queue_;
  Shared* shared_;
};

struct Settings {
  std::string url;
  int queue_size = 2;
  double time_window_s = 120.0;  // core/messages/inbox.h, TimeGuardOptions
  evermap::vo::PipelineOptions pipeline;
  evermap::vo::KeyframeResendOptions resend;
  std::string ready_file;
  std::string key_file;
};

// The command line; -1 to run, else the exit status.
int parse(int argc, char** argv, Settings* s) {
  using evermap::CommandLine;
  CommandLine cli("evermap-vo-proc",
                  "Visual odometry on LCM: STEREO_CALIB + STEREO or RGBD in, VO_DELTA and "
                  "KEYFRAME out; KEYFRAME_REQUEST in, KEYFRAME_PART out (keyframes asked for "
                  "again).");
  cli.value("--lcm-url", &s->url, "URL", "LCM provider (default: $LCM_DEFAULT_URL or LCM's)");
  cli.value("--queue", &s->queue_size, "N", "frames waiting at most (default 2); older dropped")
      .in(1, 1000);
  cli.value("--time-window-s", &s->time_window_s, "S",
            "a frame stamped more than S s from the stream's clock waits for confirmation "
            "(default 120; 0: off)")
      .nonNegative();
  cli.value("--ready-file", &s->ready_file, "PATH", "create PATH once subscribed (for scripts)");
  evermap::messages::declareKeyOption(cli, &s->key_file);
  bool print_options = false;
  cli.flag("--print-options", &print_options, "print the odometry options in words and exit");
  cli.options(&s->pipeline);
  cli.options(&s->resend, "resend.");
  // Short forms, applied after --config as --set is.
  cli.alias("--no-descriptors", "odometry.keyframe_descriptors", "", "false");
  cli.alias("--keyframe-inliers", "odometry.keyframe_inlier_threshold", "N");
  cli.check([s] {
    if (evermap::Status r = s->resend.validate(); !r) return r;
    return s->pipeline.validate();
  });
  if (const int code = cli.parseOrExit(argc, argv); code >= 0) return code;
  if (print_options) {
    std::printf("%s\n", s->pipeline.odometry.describe().c_str());
    return 0;
  }
  cli.logChangedOptions();
  return -1;
}

// One output: logged when it is not OK (a flood of bad input gets 20 lines, then one in 1000;
// bad input is counted in the pipeline's stats), then published.
void publishOutput(const evermap::vo::PipelineOutput& out, int64_t* bad_frames,
                   const evermap::messages::Outbox* sender, KeyframeChannel* keyframes) {
  const bool bad = out.result.status == evermap::vo::VoStatus::kBadInput;
  if (bad) ++*bad_frames;
  if (out.result.status != evermap::vo::VoStatus::kOk &&
      (!bad || *bad_frames <= 20 || *bad_frames % 1000 == 0)) {
    std::fprintf(
        stderr, "evermap-vo-proc: %lld %s: %s%s\n", static_cast<long long>(out.result.utime),
        evermap::vo::toString(out.result.status), out.result.message.c_str(),
        bad && *bad_frames > 20 ? (" (" + std::to_string(*bad_frames) + " bad frames)").c_str()
                                : "");
  }
  sender->publish(evermap::channels::kVoDelta, out.delta);
  if (out.keyframe) keyframes->publishNew(*out.keyframe);
  if (out.calibration) sender->publish(evermap::channels::kVoCalib, *out.calibration);
  if (!out.result.calibration_message.empty()) {
    std::fprintf(stderr, "evermap-vo-proc: self-calibration: %s\n",
                 out.result.calibration_message.c_str());
  }
}

// The worker: applies the latest calibration, runs each queued frame and publishes what it
// releases (the start-up hold's frames at its end: vo_pipeline.h); at the end, what is held.
void work(evermap::vo::BoundedQueue<QueuedFrame>* queue, Shared* shared,
          evermap::vo::VoPipeline* pipeline, const evermap::messages::Outbox* sender,
          KeyframeChannel* keyframes) {
  int64_t bad_frames = 0;
  while (auto frame = queue->pop()) {
    std::optional<Bytes> calibration;
    {
      std::lock_guard<std::mutex> lock(shared->mutex);
      calibration.swap(shared->calibration);
    }
    if (calibration) {
      if (evermap::Status s = pipeline->handleCalibrationBytes(
              calibration->data(), static_cast<int64_t>(calibration->size()));
          !s) {
        std::fprintf(stderr, "evermap-vo-proc: %s\n", s.error().message.c_str());
      }
    }
    const Bytes& bytes = frame->bytes;
    auto outs = frame->rgbd
                    ? pipeline->handleRgbdBytes(bytes.data(), static_cast<int64_t>(bytes.size()))
                    : pipeline->handleStereoBytes(bytes.data(), static_cast<int64_t>(bytes.size()));
    if (!outs) {
      std::fprintf(stderr, "evermap-vo-proc: dropped: %s\n", outs.error().message.c_str());
      continue;
    }
    for (const evermap::vo::PipelineOutput& out : *outs)
      publishOutput(out, &bad_frames, sender, keyframes);
  }
  for (const evermap::vo::PipelineOutput& out : pipeline->flush())
    publishOutput(out, &bad_frames, sender, keyframes);
}

}  // namespace

int main(int argc, char** argv) {
  Settings settings;
  if (const int code = parse(argc, argv, &settings); code >= 0) return code;
  const std::string& url = settings.url;
  const size_t queue_size = static_cast<size_t>(settings.queue_size);
  auto pipeline = evermap::vo::VoPipeline::create(settings.pipeline);
  if (!pipeline) {
    std::fprintf(stderr, "evermap-vo-proc: %s\n", pipeline.error().message.c_str());
    return 2;
  }
  auto signer = evermap::messages::makeSigner("evermap-vo-proc", settings.key_file);
  if (!signer) {
    std::fprintf(stderr, "evermap-vo-proc: %s\n", signer.error().message.c_str());
    return 2;
  }
  lcm::LCM lcm(url);
  if (!lcm.good()) {
    std::fprintf(stderr, "evermap-vo-proc: cannot open LCM (%s)\n",
                 url.empty() ? "default URL" : url.c_str());
    return 1;
  }
  evermap::StopSignals
      stop;  // SIGINT/SIGTERM; blocked before the worker starts, so it inherits that

  evermap::vo::BoundedQueue<QueuedFrame> queue(queue_size);
  Shared shared;
  Receiver receiver(&queue, &shared);
  evermap::messages::Inbox::Options input;
  input.process = "evermap-vo-proc";
  // Frames wait in the worker's queue (--queue), where the oldest are dropped and named. LCM's
  // own queue only bridges stalls of this (the LCM) thread when the CPU is shared: a frame lost
  // there is counted but not named. 16 frames (~720 kB each while they wait) are 0.8 s at 20 Hz.
  input.queue_capacity = 16;
  input.time.window_s = settings.time_window_s;
  input.signer = *signer;
  const evermap::messages::Outbox outbox(lcm, *signer);
  evermap::messages::Inbox inbox(lcm, input);
  KeyframeChannel keyframes(settings.resend, &outbox);
  inbox.subscribeBytes<evermap::stereo_image_t>(
      evermap::channels::kStereo,
      [&](const void* d, int64_t n) { return receiver.onFrame(false, d, n); });
  inbox.subscribeBytes<evermap::rgbd_image_t>(
      evermap::channels::kRgbd,
      [&](const void* d, int64_t n) { return receiver.onFrame(true, d, n); });
  inbox.subscribeBytes<evermap::stereo_calib_t>(
      evermap::channels::kStereoCalib,
      [&](const void* d, int64_t n) { return receiver.onCalibration(d, n); }, 8);
  inbox.subscribe<evermap::keyframe_request_t>(
      evermap::channels::kKeyframeRequest,
      [&](const evermap::keyframe_request_t& m) { return keyframes.onRequest(m); }, 16);

  if (!settings.ready_file.empty()) {
    if (std::FILE* f = std::fopen(settings.ready_file.c_str(), "w")) std::fclose(f);
  }

  std::thread worker([&] { work(&queue, &shared, &*pipeline, &outbox, &keyframes); });

  while (!stop.requested()) {
    lcm.handleTimeout(200);
    inbox.publishStatsEvery(1.0);
  }
  std::fprintf(stderr, "evermap-vo-proc: input: %s\n", inbox.summary().c_str());
  queue.close();
  worker.join();
  std::fprintf(stderr, "evermap-vo-proc: %s; %lld frames dropped behind (queue %zu)\n",
               pipeline->stats().report().c_str(), static_cast<long long>(queue.dropped()),
               queue_size);
  std::fprintf(stderr, "evermap-vo-proc: %s\n", keyframes.report().c_str());
  return 0;
}
