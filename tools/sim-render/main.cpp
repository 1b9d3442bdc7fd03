// evermap-sim-render: the image-level simulator (DESIGN.md section 8, docs/simulators.md).
//
//   evermap-sim-render --config FILE [--set key=value]... [--seed N] --out LOG [--stats]
//       render one session into an LCM log (STEREO_CALIB, STEREO, IMU, WHEEL_ODOM,
//       GROUND_TRUTH) and its ground truth in TUM format beside it (LOG minus .lcmlog + .gt.tum)
//   evermap-sim-render --config FILE [--set key=value]... --stats
//       render without writing; print the figures and the render rate
//   evermap-sim-render --config FILE --publish [--lcm-url URL] [--speed X]
//       publish on LCM, X times real time (default 1; 0: as fast as possible)
//   evermap-sim-render --config FILE --snapshots DIR [--every S]
//       write the left image every S seconds (default 10) as DIR/left-<seconds>.png, with what
//       the camera faces in the name (dark, blank, passerby, cab)
//   evermap-sim-render --config FILE --print-config
// With --facts FILE.csv (--out, --stats, --publish): what each stereo frame faces, one line per
// frame (utime, floor, dark_room, blank_zone, passerby, closed_cab), for judging VO per segment.
//
// Exit status: 0 done, 1 failed while running, 2 bad usage or configuration.
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <thread>
#include <vector>

#include <lcm/lcm-cpp.hpp>
#include <opencv2/imgcodecs.hpp>

#include "core/common/atomic_write.h"
#include "core/common/key_value_file.h"
#include "core/eval/trajectory.h"
#include "core/sim/image_session.h"

namespace {

namespace fs = std::filesystem;
using evermap::sim::ImageSimulator;

std::atomic<bool> g_stop{false};  // set by SIGINT/SIGTERM (a handler reaches static storage only)
void onSignal(int) { g_stop = true; }

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

void usage() {
  std::fprintf(stderr,
               "usage: evermap-sim-render --config FILE [--set key=value]... [--seed N]\n"
               "       (--out LOG [--stats] | --stats | --publish [--lcm-url URL] [--speed X] |\n"
               "        --snapshots DIR [--every S] | --print-config)\n");
}

bool parseArgs(int argc, char** argv, Args* a) {
  for (int i = 1; i < argc; ++i) {
    const std::string s = argv[i];
    auto value = [&](std::string* out) {
      if (i + 1 >= argc) return false;
      *out = argv[++i];
      return true;
    };
    std::string v;
    if (s == "--config") {
      if (!value(&a->config)) return false;
    } else if (s == "--set") {
      if (!value(&v)) return false;
      a->sets.push_back(v);
    } else if (s == "--seed") {
      if (!value(&v)) return false;
      a->sets.push_back("seed = " + v);
    } else if (s == "--out") {
      if (!value(&a->out)) return false;
    } else if (s == "--stats") {
      a->stats = true;
    } else if (s == "--publish") {
      a->publish = true;
    } else if (s == "--snapshots") {
      if (!value(&a->snapshots)) return false;
    } else if (s == "--facts") {
      if (!value(&a->facts)) return false;
    } else if (s == "--every") {
      if (!value(&v)) return false;
      a->every_s = std::atof(v.c_str());
      if (!(a->every_s > 0.0)) return false;
    } else if (s == "--print-config") {
      a->print = true;
    } else if (s == "--lcm-url") {
      if (!value(&a->lcm_url)) return false;
    } else if (s == "--speed") {
      if (!value(&v)) return false;
      char* end = nullptr;
      a->speed = std::strtod(v.c_str(), &end);
      if (end == v.c_str() || *end != '\0' || !(a->speed >= 0.0)) return false;
    } else {
      std::fprintf(stderr, "evermap-sim-render: unknown argument '%s'\n", s.c_str());
      return false;
    }
  }
  const int modes = (a->out.empty() ? 0 : 1) + (a->publish ? 1 : 0) + (a->print ? 1 : 0) +
                    (a->snapshots.empty() ? 0 : 1);
  return !a->config.empty() && (modes == 1 || (modes == 0 && a->stats));
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

}  // namespace

int main(int argc, char** argv) {
  Args args;
  if (!parseArgs(argc, argv, &args)) {
    usage();
    return 2;
  }
  auto file = evermap::KeyValueFile::load(args.config);
  if (!file) {
    std::fprintf(stderr, "evermap-sim-render: %s\n", file.error().message.c_str());
    return 2;
  }
  for (const std::string& s : args.sets) {
    if (auto st = file->set(s, "--set " + s); !st) {
      std::fprintf(stderr, "evermap-sim-render: %s\n", st.error().message.c_str());
      return 2;
    }
  }
  auto options = evermap::sim::loadImageSimOptions(*file);
  if (!options) {
    std::fprintf(stderr, "evermap-sim-render: %s\n", options.error().message.c_str());
    return 2;
  }
  if (args.print) {
    std::fputs(options->toConfigText().c_str(), stdout);
    return 0;
  }
  auto sim = ImageSimulator::create(*options);
  if (!sim) {
    std::fprintf(stderr, "evermap-sim-render: %s\n", sim.error().message.c_str());
    return 2;
  }
  if (!args.snapshots.empty()) {
    std::error_code ec;
    fs::create_directories(args.snapshots, ec);
    cv::Mat left, right;
    for (int64_t t = (*sim)->startUtime(); t <= (*sim)->endUtime(); t += static_cast<int64_t>(args.every_s * 1e6)) {
      const auto f = (*sim)->renderPair(t, &left, &right);
      char name[128];
      std::snprintf(name, sizeof name, "left-%06.1f%s%s%s%s.png", 1e-6 * static_cast<double>(t - (*sim)->startUtime()),
                    f.dark_room ? "-dark" : "", f.blank_zone ? "-blank" : "", f.passerby ? "-passerby" : "",
                    f.closed_cab ? "-cab" : "");
      const fs::path file = fs::path(args.snapshots) / name;
      if (!cv::imwrite(file.string(), left)) {
        std::fprintf(stderr, "evermap-sim-render: %s: cannot write\n", file.c_str());
        return 1;
      }
    }
    return 0;
  }
  std::signal(SIGINT, onSignal);
  std::signal(SIGTERM, onSignal);
  auto keep_going = [](double) { return !g_stop.load(); };
  evermap::Expected<evermap::sim::ImageSessionSummary> summary = evermap::makeError("nothing run");
  if (!args.out.empty()) {
    summary = evermap::sim::writeImageSessionLog(**sim, args.out, keep_going);
    if (summary) {
      const fs::path gt = groundTruthPath(args.out);
      if (auto s = writeGroundTruth(**sim, gt); !s) summary = s.error();
      else std::printf("wrote %s and %s\n", args.out.c_str(), gt.c_str());
    }
  } else if (args.publish) {
    lcm::LCM lcm(args.lcm_url);
    if (!lcm.good()) {
      std::fprintf(stderr, "evermap-sim-render: cannot open LCM (%s)\n", args.lcm_url.c_str());
      return 1;
    }
    PublishSink sink(lcm, args.speed);
    summary = (*sim)->run(sink, keep_going);
  } else {
    evermap::sim::NullSink sink;
    summary = (*sim)->run(sink, keep_going);
  }
  if (!summary) {
    std::fprintf(stderr, "evermap-sim-render: %s\n", summary.error().message.c_str());
    return 1;
  }
  if (args.stats || !args.out.empty()) std::fputs(summary->text().c_str(), stdout);
  if (!args.facts.empty()) {
    std::string text = "utime,floor,dark_room,blank_zone,passerby,closed_cab\n";
    for (const auto& [t, f] : summary->frame_facts) {
      text += std::to_string(t) + "," + std::to_string(f.floor) + "," + std::to_string(f.dark_room) + "," +
              std::to_string(f.blank_zone) + "," + std::to_string(f.passerby) + "," + std::to_string(f.closed_cab) + "\n";
    }
    if (auto s = evermap::writeFileAtomically(args.facts, text); !s) {
      std::fprintf(stderr, "evermap-sim-render: %s\n", s.error().message.c_str());
      return 1;
    }
  }
  return g_stop ? 1 : 0;
}
