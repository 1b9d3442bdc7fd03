#pragma once
// A session's events for evermap-slam-run, read from an LCM log or rendered by the image-level
// simulator on a producer thread ahead of the pipeline (which then spends its time on the
// algorithms). STEREO and RGBD events arrive decoded (LCM, then the images: zstd rows or PNG,
// a stereo pair's two in parallel, messages::fromMsg).

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "core/common/expected.h"
#include "core/messages/convert.h"
#include "core/messages/rgbd_convert.h"
#include "tools/sim/message_sink.h"
#include "vo-proc/frame_queue.h"

namespace evermap::messages {
class LogReader;
}
namespace evermap::sim {
class ImageSimulator;
}

namespace evermap::slam_run::detail {

// One event as the producer read it.
struct ReadEvent {
  std::string channel;
  int64_t timestamp = 0;
  std::vector<uint8_t> data;
  // STEREO that decoded as LCM: its images, decoded, and its utime.
  std::optional<Expected<messages::StereoFrame>> frame;
  // RGBD that decoded as LCM: its images, decoded (utime in stereo_utime).
  std::optional<Expected<messages::RgbdFrame>> rgbd_frame;
  int64_t stereo_utime = 0;
  double decode_s = 0.0;
};

// The event of `size` bytes at `p`, decoded when it is a STEREO or RGBD frame.
ReadEvent makeEvent(const std::string& channel, int64_t timestamp, const uint8_t* p, size_t size);

// A session's events, produced on their own thread at most `ahead` events in front of the
// consumer (512: about 25 frames of a 20 Hz stereo session with 200 Hz IMU, ~30 MB of decoded
// images). The producer is an LCM log or the image-level simulator rendering on the fly.
class EventStream {
 public:
  using Producer = std::function<Status(EventStream&)>;
  explicit EventStream(Producer produce, size_t ahead = 512);
  ~EventStream();
  // False once the consumer has stopped (the producer should stop too).
  bool push(ReadEvent e) { return queue_.push(std::move(e)); }
  std::optional<ReadEvent> next() { return queue_.pop(); }
  // The producer's outcome, once next() has returned nullopt.
  Status finish();

 private:
  vo::BoundedQueue<ReadEvent> queue_;
  Status status_ = Ok{};
  std::thread thread_;
};

// Rendered messages into the stream.
class StreamSink final : public sim::MessageSink {
 public:
  explicit StreamSink(EventStream& stream) : stream_(stream) {}
  void write(const std::string& channel, int64_t utime, const std::vector<uint8_t>& data) override;
  bool stopped() const { return stopped_; }

 private:
  EventStream& stream_;
  bool stopped_ = false;
};

// The producers of a session: an LCM log's events (an error for a log cut mid-event or
// damaged), or the image-level simulator's rendering (evermap-slam-run, mapping or localizing).
EventStream::Producer logProducer(std::shared_ptr<messages::LogReader> log);
EventStream::Producer renderProducer(std::shared_ptr<sim::ImageSimulator> sim);

}  // namespace evermap::slam_run::detail
