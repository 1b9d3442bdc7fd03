// evermap-sim-render: the image-level simulator (DESIGN.md section 8, docs/simulators.md).
//
//   evermap-sim-render --config FILE [--set key=value]... [--seed N] --out LOG [--stats]
//       render one session into an LCM log (STEREO_CALIB, STEREO, IMU, WHEEL_ODOM,
//       GROUND_TRUTH; RGBD_CALIB and RGBD instead of the first two with render.camera = rgbd) and
//       its ground truth in TUM format beside it (LOG minus .lcmlog + .gt.tum)
//   evermap-sim-render --config FILE [--set key=value]... --stats
//       render without writing; print the figures and the render rate
//   evermap-sim-render --config FILE --publish [--lcm-url URL] [--speed X]
//       publish on LCM, X times real time (default 1; 0: as fast as possible)
//   evermap-sim-render --config FILE --snapshots DIR [--every S]
//       write the left image every S seconds (default 10) as DIR/left-<seconds>.png, with what
//       the camera faces in the name (dark, blank, passerby, cab); with render.camera = rgbd
//       also the measured depth as DIR/depth-<seconds>.png (16-bit, in rgbd.unit_m)
//   evermap-sim-render --config FILE --print-config
// With --facts FILE.csv (--out, --stats, --publish): what each stereo frame faces, one line per
// frame (utime, floor, dark_room, blank_zone, passerby, closed_cab), for judging VO per segment.
//
// Exit status: 0 done, 1 failed while running, 2 bad usage or configuration.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <string>
#include <thread>
#include <vector>

#include <lcm/lcm-cpp.hpp>
#include <opencv2/imgcodecs.hpp>

#include "core/common/atomic_write.h"
#include "core/common/command_line.h"
#include "core/common/key_value_file.h"
#include "core/common/stop_signals.h"
#include "tools/eval/trajectory.h"
#include "tools/sim/image_session.h"
#include "tools/sim/render_progress.h"

namespace {

namespace fs = std::filesystem;
using evermap::sim::ImageSimulator;

struct Args {
  std::string config;
  std::vector<std::string> sets;
  std::string out;
  std::string lcm_url;
  double speed = 1.0;
  bool stats = false;
  bool publish = false;
  bool print = false;
  std::string snapshots;
  double every_s = 10.0;
  std::string facts;
};

// Returns -1 to run, or main's exit status (usage printed).
int parseArgs(int argc, char** argv, Args* a) {
  evermap::CommandLine cli("evermap-sim-render",
                           "The image-level simulator; one of --out (with or without --stats), "
                           "--stats, --publish, --snapshots, --print-config.");
  cli.value("--config", &a->config, "FILE", "simulation settings (config/sim-image-*.conf)", true);
  cli.repeated("--set", &a->sets, "KEY=VALUE", "override one setting (repeatable)");
  cli.value(
      "--seed",
      [a](const std::string& v) -> evermap::Status {
        a->sets.push_back("seed = " + v);
        return evermap::Ok{};
      },
      "N", "the run's seed (same as --set seed=N)");
  cli.value("--out", &a->out, "LOG", "write the session as an LCM log (ground truth beside it)");
  cli.flag("--stats", &a->stats, "print figures and timings");
  cli.flag("--publish", &a->publish, "publish on LCM instead of writing");
  cli.value("--lcm-url", &a->lcm_url, "URL", "--publish: LCM provider");
  cli.value("--speed", &a->speed, "X", "--publish: times real time (0: as fast as it renders)")
      .min(0);
  cli.value("--snapshots", &a->snapshots, "DIR",
            "write left images tagged with the failure in view");
  cli.value("--every", &a->every_s, "S", "--snapshots: one every S seconds (10)").positive();
  cli.value("--facts", &a->facts, "F.csv", "per-frame facts (failure in view) as CSV");
  cli.flag("--print-config", &a->print, "print every setting and exit");
  // The settings a --config file and --set take, listed in --help (read by the simulator).
  evermap::sim::ImageSimOptions listed;
  cli.options(&listed);
  if (const int code = cli.parseOrExit(argc, argv); code >= 0) return code;
  const int modes = (a->out.empty() ? 0 : 1) + (a->publish ? 1 : 0) + (a->print ? 1 : 0) +
                    (a->snapshots.empty() ? 0 : 1);
  if (!(modes == 1 || (modes == 0 && a->stats)) || !(a->speed >= 0.0) || !(a->every_s > 0.0)) {
    std::fprintf(stderr,
                 "evermap-sim-render: give one of --out, --publish, --snapshots, --print-config "
                 "(or --stats alone); --speed >= 0, --every > 0\n%s",
                 cli.usage().c_str());
    return 2;
  }
  return -1;
}

// Publishes every message on LCM, paced to `speed` times the data's own clock.
class PublishSink final : public evermap::sim::MessageSink {
 public:
  PublishSink(lcm::LCM& lcm, double speed) : lcm_(lcm), speed_(speed) {}
  void write(const std::string& channel, int64_t utime, const std::vector<uint8_t>& data) override {
    if (speed_ > 0.0) {
      if (first_utime_ < 0) {
        first_utime_ = utime;
        wall_start_ = std::chrono::steady_clock::now();
      }
      const auto due = wall_start_ + std::chrono::microseconds(static_cast<int64_t>(
                                         static_cast<double>(utime - first_utime_) / speed_));
      std::this_thread::sleep_until(due);
    }
    lcm_.publish(channel, data.data(), static_cast<unsigned>(data.size()));
  }

 private:
  lcm::LCM& lcm_;
  double speed_;
  int64_t first_utime_ = -1;
  std::chrono::steady_clock::time_point wall_start_;
};

fs::path groundTruthPath(const fs::path& log) {
  fs::path p = log;
  if (p.extension() == ".lcmlog") p.replace_extension();
  return p.string() + ".gt.tum";
}

evermap::Status writeGroundTruth(const ImageSimulator& sim, const fs::path& file) {
  const auto& traj = *sim.session().trajectory;
  const double rate = sim.options().sim.sensors.ground_truth_rate_hz;
  evermap::eval::Trajectory truth{file.string(), {}};
  for (int64_t k = 0;; ++k) {
    const int64_t t = sim.startUtime() + std::llround(static_cast<double>(k) * 1e6 / rate);
    if (t > sim.endUtime()) break;
    truth.poses.push_back({t * 1000, traj.at(t).world_T_body});
  }
  return evermap::eval::writeTum(truth, file);
}

// --snapshots: the left image (and depth) every --every-s seconds as PNG; main's exit status.
int writeSnapshots(ImageSimulator& sim, const Args& args) {
  std::error_code ec;
  fs::create_directories(args.snapshots, ec);
  cv::Mat left, right, depth;
  const bool rgbd = sim.options().render.camera == evermap::sim::CameraMode::kRgbd;
  for (int64_t t = sim.startUtime(); t <= sim.endUtime();
       t += static_cast<int64_t>(args.every_s * 1e6)) {
    const auto f = rgbd ? sim.renderRgbd(t, &left, &depth) : sim.renderPair(t, &left, &right);
    char name[128];
    std::snprintf(name, sizeof name, "left-%06.1f%s%s%s%s.png",
                  1e-6 * static_cast<double>(t - sim.startUtime()), f.dark_room ? "-dark" : "",
                  f.blank_zone ? "-blank" : "", f.passerby ? "-passerby" : "",
                  f.closed_cab ? "-cab" : "");
    const fs::path file = fs::path(args.snapshots) / name;
    std::string depth_name = name;
    depth_name.replace(0, 4, "depth");
    if (!cv::imwrite(file.string(), left) ||
        (rgbd && !cv::imwrite((fs::path(args.snapshots) / depth_name).string(), depth))) {
      std::fprintf(stderr, "evermap-sim-render: %s: cannot write\n", file.c_str());
      return 1;
    }
  }
  return 0;
}

// The session rendered into --out (with its ground truth beside), published on LCM, or only
// counted; `keep_going` ends it early.
evermap::Expected<evermap::sim::ImageSessionSummary> renderSession(
    ImageSimulator& sim, const Args& args, const std::function<bool(double)>& keep_going) {
  if (!args.out.empty()) {
    auto summary = evermap::sim::writeImageSessionLog(sim, args.out, keep_going);
    if (!summary) return summary;
    const fs::path gt = groundTruthPath(args.out);
    if (auto s = writeGroundTruth(sim, gt); !s) return s.error();
    std::printf("wrote %s and %s\n", args.out.c_str(), gt.c_str());
    return summary;
  }
  if (args.publish) {
    lcm::LCM lcm(args.lcm_url);
    if (!lcm.good()) return evermap::makeError("cannot open LCM (", args.lcm_url, ")");
    PublishSink sink(lcm, args.speed);
    return sim.run(sink, keep_going);
  }
  evermap::sim::NullSink sink;
  return sim.run(sink, keep_going);
}

// --facts: what each frame showed, as CSV.
evermap::Status writeFacts(const std::string& file,
                           const evermap::sim::ImageSessionSummary& summary) {
  std::string text = "utime,floor,dark_room,blank_zone,passerby,closed_cab\n";
  for (const auto& [t, f] : summary.frame_facts) {
    text += std::to_string(t) + "," + std::to_string(f.floor) + "," + std::to_string(f.dark_room) +
            "," + std::to_string(f.blank_zone) + "," + std::to_string(f.passerby) + "," +
            std::to_string(f.closed_cab) + "\n";
  }
  return evermap::writeFileAtomically(file, text);
}

}  // namespace

int main(int argc, char** argv) {
  Args args;
  if (const int code = parseArgs(argc, argv, &args); code >= 0) return code;
  auto options =
      evermap::sim::loadConfig(evermap::sim::loadImageSimOptions, args.config, args.sets, "--set");
  if (!options) {
    std::fprintf(stderr, "evermap-sim-render: %s\n", options.error().message.c_str());
    return 2;
  }
  if (args.print) {
    std::fputs(options->toConfigText().c_str(), stdout);
    return 0;
  }
  evermap::ProgressReporter setup("evermap-sim-render", "frames", evermap::printToStderr);
  auto sim = ImageSimulator::create(*options, &setup);
  if (!sim) {
    std::fprintf(stderr, "evermap-sim-render: %s\n", sim.error().message.c_str());
    return 2;
  }
  if (!args.snapshots.empty()) return writeSnapshots(**sim, args);
  evermap::StopSignals stop;  // SIGINT/SIGTERM end a render early
  auto keep_going =
      evermap::sim::withProgressLines(**sim, [&stop](double) { return !stop.requested(); });
  const auto summary = renderSession(**sim, args, keep_going);
  if (!summary) {
    std::fprintf(stderr, "evermap-sim-render: %s\n", summary.error().message.c_str());
    return 1;
  }
  if (args.stats || !args.out.empty()) std::fputs(summary->text().c_str(), stdout);
  if (!args.facts.empty()) {
    if (auto s = writeFacts(args.facts, *summary); !s) {
      std::fprintf(stderr, "evermap-sim-render: %s\n", s.error().message.c_str());
      return 1;
    }
  }
  return stop.requested() ? 1 : 0;
}
