#pragma once
// The first sign of a ride (FLOOR EVENT_VERTICAL_MOTION, elevator_tracker.h). The matched
// filter confirms a start pulse only once every template window that could overlap it has
// passed: up to the longest template (10 s) after the pulse, 12-14 s after the cab started on
// the rendered building. A listener that must not trust its height meanwhile (the localizer:
// a pose at the floor's height in a cab already 4 m above it) needs to know at once.
//
// The watch sums the vertical acceleration (gravity removed) of the newest window_s of grid
// cells: the change of the vertical velocity over that time. On a floor it stays near zero
// whatever the body does horizontally (wheels on a floor, a person standing); a cab starting
// at 0.5-1.5 m/s^2 passes min_speed_change_m_s within about a second. Vertical motion is
// announced when the change passes it while the body is not walking (a walker's steps swing
// the vertical velocity; stairs are no ride): neither walking by the tracker's step band
// (which comes about a second late) nor shaking more than max_motion_m_s2 (the standard
// deviation of the newest second: steps 1-5 m/s^2, a cab's start under 0.5). Stillness is announced
// once nothing has passed it for hold_s, a ride has not started meanwhile, and none is under way:
// by then the matched filter would have confirmed a start (the tracker gives hold_s: its latency).
//
// A false alarm is a few seconds of "maybe moving" (an escalator, a phone turned onto another
// face, whose accelerometer reads g differently); a missed alarm leaves a listener with the
// confirmed start only, as before the watch.

#include <cstdint>
#include <deque>

#include "core/common/expected.h"
#include "core/common/option_fields.h"

namespace evermap::elevator {

struct VerticalWatchOptions {
  double window_s = 1.0;
  double min_speed_change_m_s = 0.2;
  double max_motion_m_s2 = 0.7;

  void declareOptions(OptionList& o) {
    o.add("window_s", &window_s, "s",
          "vertical motion: the vertical velocity's change over this (the newest cells)")
        .positive()
        .max(10);
    o.add("min_speed_change_m_s", &min_speed_change_m_s, "m/s",
          "vertical motion is announced when that change passes this (not walking)")
        .positive();
    o.add("max_motion_m_s2", &max_motion_m_s2, "m/s^2",
          "... and the acceleration's standard deviation over the last second is at most this")
        .positive();
  }
};

class VerticalWatch {
 public:
  enum class Change { kNone, kMotion, kStill };

  // bin_s: the tracker's grid; hold_s: its latency (see above).
  VerticalWatch(const VerticalWatchOptions& options, double bin_s, double hold_s);

  // The newest grid cell: its vertical acceleration with gravity removed (valid false: no
  // sample), the standard deviation of the newest second's, whether the body walks, and whether a
  // ride is under way (a start confirmed and not yet ended or abandoned). Cells come in index
  // order; a jump clears the window.
  Change add(int64_t index, double accel_m_s2, bool valid, double motion_m_s2, bool walking,
             bool riding);
  // The end of the data: an alarm still raised is ended (kStill), else kNone.
  Change finish();
  bool alarmed() const { return alarmed_; }

 private:
  VerticalWatchOptions o_;
  double bin_s_ = 0.1;
  int64_t window_bins_ = 10;
  int64_t hold_bins_ = 150;
  std::deque<double> window_;  // the newest cells' acceleration (0 for an empty cell)
  double sum_ = 0;
  int64_t last_index_ = -1;
  bool alarmed_ = false;
  int64_t last_seen_ = -1;  // the last cell whose change passed the threshold
};

}  // namespace evermap::elevator
