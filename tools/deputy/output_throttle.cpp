#include "tools/deputy/output_throttle.h"

#include <algorithm>
#include <cmath>

namespace evermap::deputy {

void OutputThrottleOptions::declareOptions(OptionList& o) {
  o.add("flush_interval_ms", &flush_interval_ms, "ms",
        "a process's lines wait at most this long before they are sent")
      .nonNegative();
  o.add("max_message_bytes", &max_message_bytes, "bytes", "a batch is sent early at this size")
      .min(64);
  o.add("max_bytes_per_s", &max_bytes_per_s, "bytes/s", "sustained output allowed per process")
      .positive();
  o.add("burst_bytes", &burst_bytes, "bytes",
        "sent at once after a quiet period (at least max_message_bytes)")
      .positive();
}

Status OutputThrottleOptions::validate() const {
  if (Status s = checkOptionRanges(*this, "output."); !s) return s;
  if (!(burst_bytes >= static_cast<double>(max_message_bytes))) {
    return makeError("output.burst_bytes must be >= output.max_message_bytes (", max_message_bytes,
                     "), got ", burst_bytes);
  }
  return Ok{};
}

void OutputThrottle::addLine(const std::string& name, const std::string& line,
                             Clock::time_point now) {
  Stream& s = streams_[name];
  if (!s.initialised) {
    s.tokens = options_.burst_bytes;
    s.last_refill = now;
    s.initialised = true;
  }
  const double elapsed_s = std::chrono::duration<double>(now - s.last_refill).count();
  s.tokens = std::min(options_.burst_bytes, s.tokens + elapsed_s * options_.max_bytes_per_s);
  s.last_refill = now;
  const double cost = static_cast<double>(line.size() + 1);
  if (cost > s.tokens) {
    ++s.dropped_since_sent;
    ++dropped_total_;
    return;
  }
  s.tokens -= cost;
  if (s.pending.empty()) s.first_pending = now;
  if (s.dropped_since_sent > 0) {
    s.pending += "[deputy: " + std::to_string(s.dropped_since_sent) +
                 " lines not sent, over the output rate; see the log file]\n";
    s.dropped_since_sent = 0;
  }
  // A line longer than a whole message is cut; the log file keeps it whole.
  const size_t room = options_.max_message_bytes - 1;
  s.pending.append(line, 0, std::min(line.size(), room));
  s.pending += '\n';
}

std::vector<OutputThrottle::Batch> OutputThrottle::takeDue(Clock::time_point now, bool flush_all) {
  std::vector<Batch> out;
  const auto interval = std::chrono::duration_cast<Clock::duration>(
      std::chrono::duration<double, std::milli>(options_.flush_interval_ms));
  for (auto& [name, s] : streams_) {
    if (s.pending.empty()) continue;
    if (!flush_all && s.pending.size() < options_.max_message_bytes &&
        now - s.first_pending < interval) {
      continue;
    }
    // Split at line ends so no message exceeds max_message_bytes (by more than one line).
    size_t start = 0;
    while (start < s.pending.size()) {
      size_t end = start + options_.max_message_bytes;
      if (end >= s.pending.size()) {
        end = s.pending.size();
      } else {
        const size_t nl = s.pending.rfind('\n', end - 1);
        end = (nl != std::string::npos && nl >= start) ? nl + 1 : s.pending.find('\n', end) + 1;
      }
      out.push_back({name, s.pending.substr(start, end - start)});
      start = end;
    }
    s.pending.clear();
  }
  return out;
}

OutputThrottle::Clock::time_point OutputThrottle::nextDue() const {
  auto due = Clock::time_point::max();
  const auto interval = std::chrono::duration_cast<Clock::duration>(
      std::chrono::duration<double, std::milli>(options_.flush_interval_ms));
  for (const auto& [name, s] : streams_) {
    if (!s.pending.empty()) due = std::min(due, s.first_pending + interval);
  }
  return due;
}

}  // namespace evermap::deputy
