// evermap-imu-proc: IMU -> ATTITUDE (roll, pitch, covariance, the gyro's heading). Only options,
// LCM and the loop; the filter is evermap::imu::AttitudeFilter.

#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>

#include <evermap/attitude_t.hpp>
#include <evermap/imu_t.hpp>
#include <lcm/lcm-cpp.hpp>

#include "core/common/option_fields.h"
#include "core/common/stop_signals.h"
#include "core/messages/channels.h"
#include "core/messages/inbox.h"
#include "imu-proc/attitude_stream.h"

namespace {

struct ProcOptions {
  double publish_rate_hz = 50.0;
  double time_window_s = 120.0;
  template <typename F>
  void forEachField(F&& f) {
    f("publish_rate_hz", publish_rate_hz, "Hz (at most the IMU rate)");
    f("time_window_s", time_window_s,
      "s: an IMU sample stamped further from the stream's clock waits for confirmation (0: off)");
  }
};

// The handler owns the stream.
struct Publisher {
  lcm::LCM* lcm;
  evermap::imu::AttitudeStream stream;
  bool announced = false;
  void onImu(const evermap::imu_t& msg) {
    if (auto out = stream.add(msg)) lcm->publish(evermap::channels::kAttitude, &*out);
    if (!announced && stream.filter().initialized()) {
      // Once, when the start-up window has decided (gyroscope_mode -1: auto).
      announced = true;
      std::fprintf(stderr, "evermap-imu-proc: %s\n",
                   stream.filter().accelOnly() ? "mode accelerometer only (no gyroscope)"
                                               : "mode gyroscope + accelerometer");
    }
  }
};

void usage() {
  std::printf(
      "usage: evermap-imu-proc [--lcm-url URL] [--config FILE] [--set key=value]... "
      "[--print-options]\n"
      "Subscribes IMU, publishes ATTITUDE.\n");
}

}  // namespace

int main(int argc, char** argv) {
  using namespace evermap;
  imu::AttitudeFilterOptions options;
  imu::HeadingOptions heading;
  ProcOptions proc;
  std::string url;
  bool print = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool has_value = i + 1 < argc;
    Status st = Ok{};
    if (a == "--lcm-url" && has_value) {
      url = argv[++i];
    } else if (a == "--config" && has_value) {
      st = loadFields(argv[++i], &options, &heading, &proc);
    } else if (a == "--set" && has_value) {
      st = setFieldFromAssignment(argv[++i], &options, &heading, &proc);
    } else if (a == "--print-options") {
      print = true;
    } else {
      usage();
      return a == "--help" || a == "-h" ? 0 : 2;
    }
    if (!st.ok()) {
      std::fprintf(stderr, "evermap-imu-proc: %s\n", st.error().message.c_str());
      return 2;
    }
  }
  for (const Status& st : {options.validate(), heading.validate()}) {
    if (!st.ok()) {
      std::fprintf(stderr, "evermap-imu-proc: %s\n", st.error().message.c_str());
      return 2;
    }
  }
  if (!(proc.publish_rate_hz > 0) || !std::isfinite(proc.publish_rate_hz)) {
    std::fprintf(stderr, "evermap-imu-proc: publish_rate_hz must be a finite number > 0\n");
    return 2;
  }
  if (!(proc.time_window_s >= 0) || !std::isfinite(proc.time_window_s)) {
    std::fprintf(stderr, "evermap-imu-proc: time_window_s must be a finite number >= 0\n");
    return 2;
  }
  if (print) {
    std::printf("%s%s%s", describeFields(options).c_str(), describeFields(heading).c_str(),
                describeFields(proc).c_str());
    return 0;
  }

  lcm::LCM lcm(url);
  if (!lcm.good()) {
    std::fprintf(stderr, "evermap-imu-proc: cannot open LCM \"%s\"\n", url.c_str());
    return 1;
  }
  Publisher handler{&lcm, imu::AttitudeStream(options, proc.publish_rate_hz, heading)};
  messages::Inbox::Options input;
  input.process = "evermap-imu-proc";
  input.queue_capacity = 2000;  // 2 s at 1 kHz
  input.time.window_s = proc.time_window_s;
  messages::Inbox inbox(lcm, input);
  inbox.subscribe<imu_t>(channels::kImu, [&handler](const imu_t& m) { handler.onImu(m); });

  StopSignals stop;  // SIGINT/SIGTERM, polled between LCM waits
  while (!stop.requested()) {
    if (lcm.handleTimeout(200) < 0) break;
    inbox.publishStatsEvery(1.0);
  }
  std::fprintf(stderr, "evermap-imu-proc: input: %s\n", inbox.summary().c_str());
  std::fprintf(stderr, "evermap-imu-proc: %s; %s\n",
               handler.stream.filter().gateCounts().summary().c_str(),
               handler.stream.filter().counts().summary().c_str());
  return 0;
}
