#include "tools/slam-run/frame_dropper.h"

#include <charconv>
#include <cmath>
#include <fstream>
#include <string>
#include <string_view>

namespace evermap::slam_run {

Status FrameDropOptions::validate() const {
  if (!(fraction >= 0.0 && fraction <= 0.5)) {
    return makeError("drop fraction ", fraction, " is outside [0, 0.5]");
  }
  if (!(burst_probability >= 0.0 && burst_probability <= 1.0)) {
    return makeError("drop burst_probability ", burst_probability, " is outside [0, 1]");
  }
  if (burst_frames < 1) return makeError("drop burst_frames ", burst_frames, " must be >= 1");
  return Ok{};
}

Expected<std::vector<int64_t>> readDroppedFrames(const std::filesystem::path& file) {
  std::ifstream in(file);
  if (!in) return makeError(file.string(), ": cannot read the dropped frames");
  static constexpr std::string_view kMark = "dropped behind the queue: frame ";
  std::vector<int64_t> utimes;
  bool summary = false;  // vo-proc's exit line, "...; N frames dropped behind (queue Q)"
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    summary = summary || line.find(" frames dropped behind") != std::string::npos;
    std::string_view text = line;
    if (const size_t at = text.find(kMark); at != std::string_view::npos) {
      text.remove_prefix(at + kMark.size());
    }
    while (!text.empty() && (text.back() == ' ' || text.back() == '\r')) text.remove_suffix(1);
    int64_t utime = 0;
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), utime);
    if (ec != std::errc() || end != text.data() + text.size() || text.empty()) continue;
    if (!utimes.empty() && utime < utimes.back()) {
      return makeError(file.string(), ":", number, ": frame ", utime, " is before the one above (",
                       utimes.back(), "): the log of several runs? Give one run's");
    }
    utimes.push_back(utime);
  }
  if (utimes.empty() && !summary) {
    return makeError(file.string(), ": no frame time (vo-proc's \"", kMark,
                     "U\" lines, or one integer a line)");
  }
  return utimes;
}

FrameDropper::FrameDropper(const FrameDropOptions& options)
    : burst_probability_(options.burst_probability),
      burst_frames_(options.burst_frames),
      rng_(options.seed),
      utimes_(options.utimes.begin(), options.utimes.end()) {
  const double f = options.fraction;
  const double mean_length = 1.0 + options.burst_probability * (options.burst_frames - 1);
  // f = L q / (1 - q + L q)  <=>  q = f / (L (1 - f) + f)
  start_probability_ = f > 0.0 ? f / (mean_length * (1.0 - f) + f) : 0.0;
}

bool FrameDropper::drop(int64_t utime) {
  ++frames_;
  if (utimes_.count(utime) > 0) {
    ++dropped_;
    ++named_dropped_;
    return true;
  }
  if (remaining_ == 0 && start_probability_ > 0.0) {
    std::uniform_real_distribution<double> u(0.0, 1.0);
    if (u(rng_) < start_probability_) {
      remaining_ = u(rng_) < burst_probability_ ? burst_frames_ : 1;
    }
  }
  if (remaining_ == 0) return false;
  --remaining_;
  ++dropped_;
  return true;
}

}  // namespace evermap::slam_run
