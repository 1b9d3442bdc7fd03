// evermap-vo-run: visual odometry over an LCM log (e.g. from evermap-euroc2lcm), in one
// process, deterministically (vo-proc/offline_runner.h). Writes the trajectory in TUM format
// and per-frame statistics as CSV.
#include <cstdio>
#include <string>
#include <vector>

#include "core/common/command_line.h"
#include "vo-proc/offline_runner.h"

int main(int argc, char** argv) {
  evermap::vo::OfflineOptions options;
  std::string stats, output_log;
  std::vector<std::string> positional;
  bool no_descriptors = false;
  evermap::CommandLine cli("evermap-vo-run",
                           "Visual odometry over an LCM log, in one process; writes the trajectory (TUM).");
  cli.positional(&positional, "LOG TRAJECTORY.tum",
                 "the LCM log with STEREO_CALIB and STEREO (evermap-euroc2lcm output); the TUM file of the tracked frames");
  cli.flag("--body", &options.body_frame, "body (IMU) frame poses instead of the left camera's");
  cli.value("--stats", &stats, "FILE.csv", "per-frame statistics");
  cli.value("--output-log", &output_log, "FILE", "the VO_DELTA and KEYFRAME messages, as an LCM log");
  cli.value("--max-frames", &options.max_frames, "N", "stop after N stereo frames");
  cli.value("--keyframe-inliers", &options.pipeline.odometry.keyframe_inlier_threshold, "N",
            "new keyframe below N inliers (default 150)");
  cli.flag("--no-descriptors", &no_descriptors, "no ORB descriptors at keyframes");
  if (const int code = cli.parseOrExit(argc, argv); code >= 0) return code;
  if (no_descriptors) options.pipeline.odometry.keyframe_descriptors = false;
  options.output_log = output_log;
  if (positional.size() != 2) {
    std::fprintf(stderr, "evermap-vo-run: expected LOG and TRAJECTORY.tum, got %zu words (--help)\n",
                 positional.size());
    return 2;
  }
  const auto summary = evermap::vo::runOffline(positional[0], options);
  if (!summary) {
    std::fprintf(stderr, "evermap-vo-run: %s\n", summary.error().message.c_str());
    return 1;
  }
  if (summary->trajectory.empty()) {
    std::fprintf(stderr, "evermap-vo-run: no frame was tracked\n%s\n",
                 summary->report().c_str());
    return 1;
  }
  if (auto s = evermap::eval::writeTum(summary->trajectory, positional[1]); !s) {
    std::fprintf(stderr, "evermap-vo-run: %s\n", s.error().message.c_str());
    return 1;
  }
  if (!stats.empty()) {
    if (auto s = evermap::vo::writeFrameStatsCsv(summary->frames, stats); !s) {
      std::fprintf(stderr, "evermap-vo-run: %s\n", s.error().message.c_str());
      return 1;
    }
  }
  std::printf("%s\nwrote %s\n", summary->report().c_str(), positional[1].c_str());
  return 0;
}
