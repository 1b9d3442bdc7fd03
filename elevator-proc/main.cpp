// evermap-elevator-proc: IMU + ATTITUDE -> FLOOR at the start and end of elevator rides.
// Only options, LCM and the loop; the detector is evermap::elevator::ElevatorTracker.
//
// Threading: LCM handlers run on this thread, in handle(); nothing else touches the tracker.

#include <cmath>
#include <cstdio>
#include <deque>
#include <string>

#include <evermap/attitude_t.hpp>
#include <evermap/floor_t.hpp>
#include <evermap/imu_t.hpp>
#include <lcm/lcm-cpp.hpp>

#include "core/imu/lcm_convert.h"
#include "core/messages/channels.h"
#include "core/messages/lcm_process.h"
#include "elevator-proc/elevator_tracker.h"
#include "elevator-proc/lcm_convert.h"

namespace {

// IMU samples wait (briefly) for the ATTITUDE of their time stamp: imu-proc publishes
// ATTITUDE after it has seen the IMU sample, so the attitude arrives a little later.
class Node {
 public:
  Node(const evermap::messages::Outbox* out,
       const evermap::elevator::ElevatorTrackerOptions& options)
      : out_(out), tracker_(options) {}

  void onImu(const evermap::imu_t& msg) {
    pending_.push_back(evermap::imu::fromLcm(msg));
    // Never hold more than ~2 s at 1 kHz: without ATTITUDE, samples go through unmatched
    // (and are counted by the tracker as "without attitude").
    while (pending_.size() > 2000) flushFront(nullptr);
  }

  evermap::Status onAttitude(const evermap::attitude_t& msg) {
    const evermap::imu::Attitude att = evermap::imu::fromLcm(msg);
    if (!std::isfinite(att.roll_rad) || !std::isfinite(att.pitch_rad)) {
      ++bad_attitudes_;
      return evermap::makeError("ATTITUDE ", msg.utime, ": non-finite roll or pitch");
    }
    latest_ = att;
    have_attitude_ = true;
    // Every sample up to this attitude's time uses it (it is at most one IMU period newer
    // than the ones imu-proc decimated away).
    while (!pending_.empty() && pending_.front().utime <= att.utime) flushFront(&latest_);
    return evermap::Ok{};
  }

  const evermap::elevator::ElevatorTracker& tracker() const { return tracker_; }
  int64_t badAttitudes() const { return bad_attitudes_; }

 private:
  void flushFront(const evermap::imu::Attitude* att) {
    const evermap::imu::ImuSample s = pending_.front();
    pending_.pop_front();
    if (!att && have_attitude_) att = &latest_;
    for (const auto& e : tracker_.add(s, att)) {
      const evermap::floor_t out = evermap::elevator::toLcm(e);
      out_->publish(evermap::channels::kFloor, out);
      const bool ride = out.event == evermap::floor_t::EVENT_RIDE_START ||
                        out.event == evermap::floor_t::EVENT_RIDE_END;
      std::fprintf(stderr, "evermap-elevator-proc: %s %s floor %d height %.2f m (+-%.2f)%s\n",
                   ride ? "ride" : "vertical", evermap::elevator::floorEventName(out.event),
                   out.floor_index, out.height_m, out.height_sigma_m,
                   out.new_floor ? " new floor" : "");
    }
  }

  const evermap::messages::Outbox* out_;
  evermap::elevator::ElevatorTracker tracker_;
  std::deque<evermap::imu::ImuSample> pending_;
  evermap::imu::Attitude latest_;
  bool have_attitude_ = false;
  int64_t bad_attitudes_ = 0;
};

struct Settings {
  evermap::elevator::ElevatorTrackerOptions tracker;
  double time_window_s = 120.0;  // core/messages/inbox.h, TimeGuardOptions
};

void declare(evermap::CommandLine& cli, Settings* s) {
  cli.value("--time-window-s", &s->time_window_s, "S",
            "a sample stamped more than S s from the stream's clock waits for confirmation "
            "(default 120; 0: off)")
      .nonNegative();
  cli.options(&s->tracker);
  cli.check([s] { return s->tracker.validate(); });
}

}  // namespace

int main(int argc, char** argv) {
  using namespace evermap;
  Settings settings;
  messages::LcmProcess process("evermap-elevator-proc",
                               "Subscribes IMU and ATTITUDE, publishes FLOOR.");
  declare(process.cli(), &settings);
  if (const int code = process.start(argc, argv); code >= 0) return code;
  Node node(&process.outbox(), settings.tracker);
  // 2 s of IMU at 1 kHz
  messages::Inbox& inbox = process.inbox(2000, settings.time_window_s);
  inbox.subscribe<imu_t>(channels::kImu, [&node](const imu_t& m) { node.onImu(m); });
  inbox.subscribe<attitude_t>(channels::kAttitude,
                              [&node](const attitude_t& m) { return node.onAttitude(m); });
  process.run();
  std::fprintf(stderr, "evermap-elevator-proc: %s; gate: %s; bad attitudes %lld\n",
               node.tracker().counts().summary().c_str(),
               node.tracker().gateCounts().summary().c_str(),
               static_cast<long long>(node.badAttitudes()));
  return 0;
}
