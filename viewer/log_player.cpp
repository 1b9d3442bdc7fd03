#include "viewer/log_player.h"

#include <algorithm>
#include <system_error>

#include "core/messages/channels.h"

namespace evermap::viewer {

Status LogPlayerOptions::validate() const {
  if (max_bytes < 1) return makeError("max_bytes: must be >= 1, got ", max_bytes);
  if (trail_poses < 0) return makeError("trail_poses: must be >= 0, got ", trail_poses);
  return Ok{};
}

Expected<LogPlayer> LogPlayer::open(const std::filesystem::path& file, const std::set<std::string>& channels,
                                    const LogPlayerOptions& options) {
  if (Status s = options.validate(); !s) return s.error();
  std::error_code ec;
  if (!std::filesystem::is_regular_file(file, ec)) return makeError(file.string(), ": no such log (not a file)");
  lcm::LogFile log(file.string(), "r");
  if (!log.good()) return makeError(file.string(), ": cannot open as an LCM log");
  LogPlayer p;
  p.o_ = options;
  int64_t bytes = 0;
  while (const lcm::LogEvent* e = log.readNextEvent()) {
    if (!channels.count(e->channel) || e->datalen < 0) continue;
    bytes += e->datalen;
    if (bytes > options.max_bytes)
      return makeError(file.string(), ": more than ", options.max_bytes, " bytes of messages on the viewer's channels");
    const auto* d = static_cast<const uint8_t*>(e->data);
    p.events_.push_back(Event{e->timestamp, e->channel, std::vector<uint8_t>(d, d + e->datalen)});
  }
  // lcm-logger writes in receive order; a log stitched from several need not be.
  std::stable_sort(p.events_.begin(), p.events_.end(),
                   [](const Event& a, const Event& b) { return a.timestamp < b.timestamp; });
  p.rewind();
  return p;
}

int64_t LogPlayer::playTo(int64_t utime, const Send& send_event) {
  size_t end = next_;
  while (end < events_.size() && events_[end].timestamp <= utime) ++end;
  // Of the stretch, the last MAP_GRAPH and the last trail_poses POSEs (the page shows no more).
  size_t last_graph = events_.size();
  size_t poses_left = static_cast<size_t>(o_.trail_poses);
  std::vector<bool> send(end - next_, true);  // which of the stretch go out
  for (size_t k = end; k-- > next_;) {
    const std::string& ch = events_[k].channel;
    if (ch == channels::kMapGraph) {
      if (last_graph != events_.size()) send[k - next_] = false;
      last_graph = k;
    } else if (ch == channels::kPose) {
      if (poses_left == 0) send[k - next_] = false; else --poses_left;
    }
  }
  int64_t sent = 0;
  for (size_t k = next_; k < end; ++k) {
    if (!send[k - next_]) continue;
    const Event& e = events_[k];
    send_event(e.channel, e.data.data(), e.data.size());
    ++sent;
  }
  if (end > next_) position_ = events_[end - 1].timestamp;
  position_ = std::max(position_, std::min(utime, endUtime()));
  next_ = end;
  return sent;
}

}  // namespace evermap::viewer
