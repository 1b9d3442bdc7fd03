#pragma once
// `evermap-viewer --log file.lcmlog`: the viewer's channels of an LCM log, held in memory and
// played into an in-process LCM (memq://) that the LcmListener reads, so a log goes through
// the same checked decoding path as live messages. The page's time slider seeks; a seek back
// restarts the viewer's state and replays up to the new time, sending of the skipped stretch
// only what the page shows (the last MAP_GRAPH, the last `trail_poses` POSEs, every other
// message: they feed counts and plots).
//
// Time is the log's event timestamp (when lcm-logger received the message), microseconds, as
// lcm-logplayer plays it. Camera images would not fit in memory: of STEREO (when asked for) one
// per `image_period_us` of log time is kept, with the newest KEYFRAME before it (the features
// the page draws on it), within `max_image_bytes`; KEYFRAMEs are kept with an image only.

#include <cstdint>
#include <filesystem>
#include <functional>
#include <set>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "core/common/expected.h"

namespace evermap::viewer {

struct LogPlayerOptions {
  // Most bytes of messages kept from the log; a larger log is refused (an error naming it).
  int64_t max_bytes = int64_t{1} << 30;
  // POSEs sent when a seek skips a stretch (the page's trail).
  int trail_poses = 600;
  // Log time between two STEREO messages kept (the page shows one camera image at a time).
  int64_t image_period_us = 1'000'000;
  // Most bytes of kept STEREO and KEYFRAME messages: beyond it every other kept image goes and
  // the period doubles (a long log keeps fewer images, never fails for them).
  int64_t max_image_bytes = int64_t{256} << 20;

  Status validate() const;
};

// Playing speeds the page may ask for, x real time (the command line's --speed as well).
inline constexpr double kMinLogSpeed = 0.01;
inline constexpr double kMaxLogSpeed = 1000.0;

// One of the page's commands to the log player: "play", "pause", "seek UTIME" (a log time,
// microseconds) or "speed X" (x real time, within [kMinLogSpeed, kMaxLogSpeed]).
struct LogCommand {
  enum class Kind { kPlay, kPause, kSeek, kSpeed };
  Kind kind = Kind::kPlay;
  int64_t utime = 0;   // kSeek
  double speed = 1.0;  // kSpeed
};
// The command `text` says, or nothing when it says none of the above (the page's text is
// untrusted: a number that does not parse whole, is not finite or is out of range is nothing).
std::optional<LogCommand> parseLogCommand(std::string_view text);

class LogPlayer {
 public:
  // Reads the events of `channels` from `file`. Errors: no such file, not an LCM log, too big.
  static Expected<LogPlayer> open(const std::filesystem::path& file,
                                  const std::set<std::string>& channels,
                                  const LogPlayerOptions& options = {});

  int64_t startUtime() const { return events_.empty() ? 0 : events_.front().timestamp; }
  int64_t endUtime() const { return events_.empty() ? 0 : events_.back().timestamp; }
  size_t events() const { return events_.size(); }
  // Timestamp of the last event sent (startUtime() - 1 before any).
  int64_t position() const { return position_; }

  // STEREO messages kept, and the period between them after any thinning (microseconds).
  int64_t images() const { return images_; }
  int64_t imagePeriodUs() const { return image_period_us_; }

  // Hands `send` the events after position() up to `utime` (inclusive), in order, thinned as
  // the header says (of a stretch, only its last image and keyframe); returns how many it sent.
  using Send = std::function<void(const std::string& channel, const void* data, size_t size)>;
  int64_t playTo(int64_t utime, const Send& send);
  // Back to before the first event (the caller restarts the state it feeds).
  void rewind() {
    next_ = 0;
    position_ = startUtime() - 1;
  }

 private:
  struct Event {
    int64_t timestamp;
    std::string channel;
    std::vector<uint8_t> data;
  };
  std::vector<Event> events_;
  size_t next_ = 0;
  int64_t position_ = -1;
  int64_t images_ = 0;
  int64_t image_period_us_ = 0;
  LogPlayerOptions o_;
};

}  // namespace evermap::viewer
