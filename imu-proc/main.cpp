// evermap-imu-proc: IMU -> ATTITUDE (roll, pitch, covariance, the gyro's heading). Only options,
// LCM and the loop; the filter is evermap::imu::AttitudeFilter.

#include <cstdio>
#include <string>

#include <evermap/attitude_t.hpp>
#include <evermap/imu_t.hpp>
#include <lcm/lcm-cpp.hpp>

#include "core/messages/channels.h"
#include "core/messages/lcm_process.h"
#include "imu-proc/attitude_stream.h"

namespace {

struct ProcOptions {
  double publish_rate_hz = 50.0;
  double time_window_s = 120.0;
  void declareOptions(evermap::OptionList& o) {
    o.add("publish_rate_hz", &publish_rate_hz, "Hz", "ATTITUDE rate (at most the IMU's)")
        .positive();
    o.add("time_window_s", &time_window_s, "s",
          "a sample stamped further from the stream's clock waits for confirmation; 0: off")
        .nonNegative();
  }
};

// The handler owns the stream.
struct Publisher {
  const evermap::messages::Outbox* out;
  evermap::imu::AttitudeStream stream;
  bool announced = false;
  void onImu(const evermap::imu_t& msg) {
    if (auto out_msg = stream.add(msg)) out->publish(evermap::channels::kAttitude, *out_msg);
    if (!announced && stream.filter().initialized()) {
      // Once, when the start-up window has decided (gyroscope_mode -1: auto).
      announced = true;
      std::fprintf(stderr, "evermap-imu-proc: %s\n",
                   stream.filter().accelOnly() ? "mode accelerometer only (no gyroscope)"
                                               : "mode gyroscope + accelerometer");
    }
  }
};

struct Settings {
  evermap::imu::AttitudeFilterOptions filter;
  evermap::imu::HeadingOptions heading;
  ProcOptions proc;
};

void declare(evermap::CommandLine& cli, Settings* s) {
  cli.options(&s->filter);
  cli.options(&s->heading, "heading.");
  cli.options(&s->proc);
  cli.check([s] { return s->filter.validate(); });
  cli.check([s] { return s->heading.validate(); });
}

}  // namespace

int main(int argc, char** argv) {
  using namespace evermap;
  Settings settings;
  messages::LcmProcess process("evermap-imu-proc",
                               "Subscribes IMU, publishes ATTITUDE (roll, pitch, covariance, "
                               "the gyro's heading).");
  declare(process.cli(), &settings);
  if (const int code = process.start(argc, argv); code >= 0) return code;
  Publisher handler{
      &process.outbox(),
      imu::AttitudeStream(settings.filter, settings.proc.publish_rate_hz, settings.heading)};
  // 2 s at 1 kHz
  process.inbox(2000, settings.proc.time_window_s)
      .subscribe<imu_t>(channels::kImu, [&handler](const imu_t& m) { handler.onImu(m); });
  process.run();
  std::fprintf(stderr, "evermap-imu-proc: %s; %s\n",
               handler.stream.filter().gateCounts().summary().c_str(),
               handler.stream.filter().counts().summary().c_str());
  return 0;
}
