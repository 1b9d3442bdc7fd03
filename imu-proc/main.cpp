// evermap-imu-proc: IMU -> ATTITUDE (roll, pitch, covariance, the gyro's heading). Only options,
// LCM and the loop; the filter is evermap::imu::AttitudeFilter.

#include <cstdio>
#include <string>

#include <evermap/attitude_t.hpp>
#include <evermap/imu_t.hpp>
#include <lcm/lcm-cpp.hpp>

#include "core/common/command_line.h"
#include "core/common/stop_signals.h"
#include "core/messages/channels.h"
#include "core/messages/inbox.h"
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

struct Settings {
  evermap::imu::AttitudeFilterOptions filter;
  evermap::imu::HeadingOptions heading;
  ProcOptions proc;
  std::string url;
};

// The command line; -1 to run, else the exit status.
int parse(int argc, char** argv, Settings* s) {
  using namespace evermap;
  CommandLine cli("evermap-imu-proc",
                  "Subscribes IMU, publishes ATTITUDE (roll, pitch, covariance, the gyro's "
                  "heading).");
  cli.value("--lcm-url", &s->url, "URL", "LCM provider (default: $LCM_DEFAULT_URL)");
  cli.options(&s->filter);
  cli.options(&s->heading, "heading.");
  cli.options(&s->proc);
  cli.check([s] { return s->filter.validate(); });
  cli.check([s] { return s->heading.validate(); });
  cli.printConfigAlias("--print-options");
  return cli.parseOrExit(argc, argv);
}

}  // namespace

int main(int argc, char** argv) {
  using namespace evermap;
  Settings settings;
  if (const int code = parse(argc, argv, &settings); code >= 0) return code;
  const imu::AttitudeFilterOptions& options = settings.filter;
  const imu::HeadingOptions& heading = settings.heading;
  const ProcOptions& proc = settings.proc;
  const std::string& url = settings.url;

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
