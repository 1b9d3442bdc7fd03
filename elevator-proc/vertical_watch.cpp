// The first sign of a ride (vertical_watch.h).

#include "elevator-proc/vertical_watch.h"

#include <algorithm>
#include <cmath>

namespace evermap::elevator {

VerticalWatch::VerticalWatch(const VerticalWatchOptions& options, double bin_s, double hold_s)
    : o_(options),
      bin_s_(bin_s),
      window_bins_(std::max<int64_t>(1, std::llround(options.window_s / bin_s))),
      hold_bins_(std::max<int64_t>(1, std::llround(hold_s / bin_s))) {}

VerticalWatch::Change VerticalWatch::add(int64_t index, double accel_m_s2, bool valid,
                                         double motion_m_s2, bool walking, bool riding) {
  if (last_index_ >= 0 && index != last_index_ + 1) {
    window_.clear();
    sum_ = 0;
  }
  last_index_ = index;
  const double a = valid && std::isfinite(accel_m_s2) ? accel_m_s2 : 0.0;
  window_.push_back(a);
  sum_ += a;
  if (static_cast<int64_t>(window_.size()) > window_bins_) {
    sum_ -= window_.front();
    window_.pop_front();
  }
  if (riding) {
    // The confirmed start took over: its end (or abandonment) closes the episode.
    alarmed_ = false;
    return Change::kNone;
  }
  const bool full = static_cast<int64_t>(window_.size()) == window_bins_;
  const bool steady = !walking && motion_m_s2 <= o_.max_motion_m_s2;
  if (full && steady && std::abs(sum_ * bin_s_) >= o_.min_speed_change_m_s) {
    last_seen_ = index;
    if (!alarmed_) {
      alarmed_ = true;
      return Change::kMotion;
    }
  }
  if (alarmed_ && index - last_seen_ > hold_bins_) {
    alarmed_ = false;
    return Change::kStill;
  }
  return Change::kNone;
}

VerticalWatch::Change VerticalWatch::finish() {
  if (!alarmed_) return Change::kNone;
  alarmed_ = false;
  return Change::kStill;
}

}  // namespace evermap::elevator
