// evermap-vo-run: visual odometry over an LCM log (e.g. from evermap-euroc2lcm), in one
// process, deterministically (vo-proc/offline_runner.h). Writes the trajectory in TUM format
// and per-frame statistics as CSV.
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "vo-proc/offline_runner.h"

namespace {

constexpr const char* kUsage =
    "usage: evermap-vo-run [options] LOG TRAJECTORY.tum\n"
    "  LOG                 LCM log with STEREO_CALIB and STEREO (evermap-euroc2lcm output)\n"
    "  TRAJECTORY.tum      poses of the frames VO tracked, TUM format\n"
    "  --body              body (IMU) frame poses instead of the left camera's\n"
    "  --stats FILE.csv    per-frame statistics\n"
    "  --output-log FILE   the VO_DELTA and KEYFRAME messages, as an LCM log\n"
    "  --max-frames N      stop after N stereo frames\n"
    "  --keyframe-inliers N  new keyframe below N inliers (default 150)\n"
    "  --no-descriptors    no ORB descriptors at keyframes\n";

}  // namespace

int main(int argc, char** argv) {
  evermap::vo::OfflineOptions options;
  std::string stats;
  std::vector<std::string> positional;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--body") {
      options.body_frame = true;
    } else if (a == "--stats" && i + 1 < argc) {
      stats = argv[++i];
    } else if (a == "--output-log" && i + 1 < argc) {
      options.output_log = argv[++i];
    } else if (a == "--max-frames" && i + 1 < argc) {
      options.max_frames = std::atoll(argv[++i]);
    } else if (a == "--keyframe-inliers" && i + 1 < argc) {
      options.pipeline.odometry.keyframe_inlier_threshold = std::atoi(argv[++i]);
    } else if (a == "--no-descriptors") {
      options.pipeline.odometry.keyframe_descriptors = false;
    } else if (a == "-h" || a == "--help") {
      std::fputs(kUsage, stdout);
      return 0;
    } else if (!a.empty() && a[0] == '-') {
      std::fprintf(stderr, "evermap-vo-run: unknown option %s\n%s", a.c_str(), kUsage);
      return 2;
    } else {
      positional.push_back(a);
    }
  }
  if (positional.size() != 2) {
    std::fputs(kUsage, stderr);
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
