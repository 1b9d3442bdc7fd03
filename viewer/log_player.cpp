#include "viewer/log_player.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <optional>
#include <system_error>

#include "core/messages/channels.h"

namespace evermap::viewer {

std::optional<LogCommand> parseLogCommand(std::string_view text) {
  // A number that fills `s` whole.
  auto whole = [](std::string_view s, auto& value) {
    const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), value);
    return !s.empty() && ec == std::errc{} && end == s.data() + s.size();
  };
  LogCommand c;
  if (text == "play") {
    c.kind = LogCommand::Kind::kPlay;
  } else if (text == "pause") {
    c.kind = LogCommand::Kind::kPause;
  } else if (text.rfind("seek ", 0) == 0) {
    c.kind = LogCommand::Kind::kSeek;
    if (!whole(text.substr(5), c.utime)) return std::nullopt;
  } else if (text.rfind("speed ", 0) == 0) {
    c.kind = LogCommand::Kind::kSpeed;
    if (!whole(text.substr(6), c.speed) || !std::isfinite(c.speed) || c.speed < kMinLogSpeed ||
        c.speed > kMaxLogSpeed)
      return std::nullopt;
  } else {
    return std::nullopt;
  }
  return c;
}

Status LogPlayerOptions::validate() const {
  if (max_bytes < 1) return makeError("max_bytes: must be >= 1, got ", max_bytes);
  if (trail_poses < 0) return makeError("trail_poses: must be >= 0, got ", trail_poses);
  if (image_period_us < 0) return makeError("image_period_us: must be >= 0, got ", image_period_us);
  if (max_image_bytes < 0) return makeError("max_image_bytes: must be >= 0, got ", max_image_bytes);
  return Ok{};
}

Expected<LogPlayer> LogPlayer::open(const std::filesystem::path& file,
                                    const std::set<std::string>& channels,
                                    const LogPlayerOptions& options) {
  if (Status s = options.validate(); !s) return s.error();
  std::error_code ec;
  if (!std::filesystem::is_regular_file(file, ec))
    return makeError(file.string(), ": no such log (not a file)");
  lcm::LogFile log(file.string(), "r");
  if (!log.good()) return makeError(file.string(), ": cannot open as an LCM log");
  LogPlayer p;
  p.o_ = options;
  int64_t bytes = 0;
  // Camera images: kept apart while the log is read, so that thinning them is simple.
  struct Image {
    Event stereo;
    std::optional<Event> keyframe;
    int64_t bytes() const {
      return static_cast<int64_t>(stereo.data.size() + (keyframe ? keyframe->data.size() : 0));
    }
  };
  std::vector<Image> images;
  std::optional<Event> newest_keyframe;
  int64_t image_bytes = 0, last_image = 0;
  p.image_period_us_ = options.image_period_us;
  const bool want_keyframes = channels.count(channels::kKeyframe) > 0;
  auto event = [](const lcm::LogEvent* e) {
    const auto* d = static_cast<const uint8_t*>(e->data);
    return Event{e->timestamp, e->channel, std::vector<uint8_t>(d, d + e->datalen)};
  };
  while (const lcm::LogEvent* e = log.readNextEvent()) {
    if (!channels.count(e->channel) || e->datalen < 0) continue;
    if (e->channel == channels::kKeyframe) {
      newest_keyframe = event(e);
      continue;
    }
    if (e->channel == channels::kStereo) {
      if (!images.empty() && e->timestamp - last_image < p.image_period_us_) continue;
      last_image = e->timestamp;
      images.push_back(Image{event(e), want_keyframes ? std::move(newest_keyframe) : std::nullopt});
      newest_keyframe.reset();
      image_bytes += images.back().bytes();
      while (image_bytes > options.max_image_bytes && !images.empty()) {
        // Every other image goes (the last one stays: it sets the next one's time).
        std::vector<Image> kept;
        image_bytes = 0;
        for (size_t k = 0; k < images.size(); ++k) {
          if ((images.size() - 1 - k) % 2 != 0) continue;
          image_bytes += images[k].bytes();
          kept.push_back(std::move(images[k]));
        }
        if (kept.size() == images.size()) {  // one image alone is too big: none is kept
          kept.clear();
          image_bytes = 0;
        }
        images = std::move(kept);
        p.image_period_us_ = std::max<int64_t>(2 * p.image_period_us_, 1);
      }
      continue;
    }
    bytes += e->datalen;
    if (bytes > options.max_bytes)
      return makeError(file.string(), ": more than ", options.max_bytes,
                       " bytes of messages on the viewer's channels");
    p.events_.push_back(event(e));
  }
  p.images_ = static_cast<int64_t>(images.size());
  for (Image& i : images) {
    if (i.keyframe) p.events_.push_back(std::move(*i.keyframe));
    p.events_.push_back(std::move(i.stereo));
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
  size_t last_graph = events_.size(), last_image = events_.size(), last_keyframe = events_.size();
  size_t poses_left = static_cast<size_t>(o_.trail_poses);
  std::vector<bool> send(end - next_, true);  // which of the stretch go out
  for (size_t k = end; k-- > next_;) {
    const std::string& ch = events_[k].channel;
    if (ch == channels::kMapGraph) {
      if (last_graph != events_.size()) send[k - next_] = false;
      last_graph = k;
    } else if (ch == channels::kPose) {
      if (poses_left == 0)
        send[k - next_] = false;
      else
        --poses_left;
    } else if (ch == channels::kStereo) {
      if (last_image != events_.size()) send[k - next_] = false;
      last_image = k;
    } else if (ch == channels::kKeyframe) {
      if (last_keyframe != events_.size()) send[k - next_] = false;
      last_keyframe = k;
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
