#include "tools/slam-run/event_stream.h"

#include <evermap/rgbd_image_t.hpp>
#include <evermap/stereo_image_t.hpp>

#include "core/common/clocks.h"
#include "core/messages/channels.h"
#include "tools/lcmlog/log_reader.h"
#include "tools/sim/image_session.h"

namespace evermap::slam_run::detail {

ReadEvent makeEvent(const std::string& channel, int64_t timestamp, const uint8_t* p, size_t size) {
  const auto t0 = SteadyClock::now();
  ReadEvent r;
  r.channel = channel;
  r.timestamp = timestamp;
  r.data.assign(p, p + size);
  if (r.channel == channels::kStereo) {
    auto msg = messages::decodeLcm<stereo_image_t>(p, static_cast<int64_t>(size), r.channel);
    if (msg) {
      r.frame = messages::fromMsg(*msg);
      r.stereo_utime = msg->utime;
      r.data.clear();  // the decoded images are what is used
    }
  } else if (r.channel == channels::kRgbd) {
    auto msg = messages::decodeLcm<rgbd_image_t>(p, static_cast<int64_t>(size), r.channel);
    if (msg) {
      r.rgbd_frame = messages::fromMsg(*msg);
      r.stereo_utime = msg->utime;
      r.data.clear();
    }
  }
  r.decode_s = secondsSince(t0);
  return r;
}

EventStream::EventStream(Producer produce, size_t ahead)
    : queue_(ahead, vo::BoundedQueue<ReadEvent>::Full::kWait) {
  thread_ = std::thread([this, produce = std::move(produce)] {
    status_ = produce(*this);
    queue_.close();
  });
}

EventStream::~EventStream() {
  queue_.close();
  if (thread_.joinable()) thread_.join();
}

Status EventStream::finish() {
  queue_.close();
  if (thread_.joinable()) thread_.join();
  return status_;
}

void StreamSink::write(const std::string& channel, int64_t utime,
                       const std::vector<uint8_t>& data) {
  if (!stream_.push(makeEvent(channel, utime, data.data(), data.size()))) stopped_ = true;
}

EventStream::Producer logProducer(std::shared_ptr<messages::LogReader> log) {
  return [log](EventStream& out) -> Status {
    while (const messages::LogReader::Event* e = log->next()) {
      if (!out.push(makeEvent(e->channel, e->timestamp, e->data, static_cast<size_t>(e->datalen))))
        return Ok{};  // the consumer stopped (--max-session-s): what follows is not used
    }
    return log->status();  // a log cut mid-event or damaged: the map would be of part of it
  };
}

EventStream::Producer renderProducer(std::shared_ptr<sim::ImageSimulator> sim) {
  return [sim](EventStream& out) -> Status {
    StreamSink sink(out);
    auto summary = sim->run(sink, [&sink](double) { return !sink.stopped(); });
    if (!summary) return summary.error();
    return Ok{};
  };
}

}  // namespace evermap::slam_run::detail
