// evermap-vo-run: visual odometry over an LCM log (e.g. from evermap-euroc2lcm), in one
// process, deterministically (tools/vo-run/offline_runner.h). Writes the trajectory in TUM format
// and per-frame statistics as CSV.
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "core/common/command_line.h"
#include "tools/vo-run/offline_runner.h"

namespace {

// The command line of a run, beside the runner's options.
struct VoArgs {
  evermap::vo::OfflineOptions options;
  std::string stats, output_log;
  std::vector<std::string> positional;
  bool no_descriptors = false, verbose = false, no_motion_prior = false;
  double disparity_offset_px = std::nan("");
};

// The odometry's settings that the command line overrides.
void declareOdometryOptions(evermap::CommandLine& cli, VoArgs* a) {
  auto& options = a->options;
  auto& odo = options.pipeline.odometry;
  cli.value("--keyframe-inliers", &odo.keyframe_inlier_threshold, "N",
            "new reference below N inliers (default 150; a keyframe only after "
            "--keyframe-distance/--keyframe-angle)")
      .min(0);
  cli.value("--keyframe-distance", &odo.keyframe_min_translation_m, "M",
            "a new reference is a map keyframe after M metres (or --keyframe-angle)")
      .min(0);
  cli.value("--keyframe-angle", &odo.keyframe_min_rotation_rad, "RAD",
            "... or after turning RAD radians since the last keyframe")
      .min(0)
      .max(3.15);
  cli.value("--disparity-sigma", &odo.registration.disparity_sigma_px, "PX",
            "disparity noise the clique allows for along the rays (0: fixed threshold)")
      .min(0);
  cli.value("--motion-disparity-sigma", &odo.registration.motion.disparity_sigma_px, "PX",
            "disparity noise the motion estimate whitens its residuals for (0: points exact)")
      .min(0);
  cli.value("--inlier-px", &odo.registration.motion.inlier_max_reprojection_px, "PX",
            "stereo: largest reprojection error of an inlier of the motion estimate (default 1)")
      .positive();
  cli.value("--max-mean-px", &odo.registration.motion.max_mean_reprojection_px, "PX",
            "stereo: largest mean reprojection error of an accepted motion (default 1.5)")
      .positive();
  cli.value("--rgbd-inlier-px", &options.pipeline.rgbd_inlier_max_reprojection_px, "PX",
            "RGB-D: the same (default 2)")
      .positive();
  cli.value("--rgbd-max-mean-px", &options.pipeline.rgbd_max_mean_reprojection_px, "PX",
            "RGB-D: the same (default 2)")
      .positive();
  cli.value("--depth-spread", &odo.features.rgbd.max_relative_spread, "FRACTION",
            "RGB-D: refuse a corner whose 5x5 depths spread by more than FRACTION of its depth "
            "(default 0.05)")
      .positive();
  cli.value("--depth-noise", &options.pipeline.rgbd.depth_noise_per_m2, "K",
            "RGB-D: depth noise sigma_z = K z^2 (default 1.425e-3, Khoshelham & Elberink 2012)")
      .positive();
  cli.value("--disparity-offset", &a->disparity_offset_px, "PX",
            "stereo: replaces the calibration's disparity offset (right cx - left cx of a "
            "rectified STEREO_CALIB, added to every measured disparity; evermap-stereo-check "
            "--self-offset estimates it; default: the log's, which evermap-kitti2lcm "
            "--disparity-offset writes)")
      .min(-1000)
      .max(1000);
  cli.value("--clique-threshold", &odo.registration.clique.threshold_m, "M",
            "change of a pairwise distance always consistent")
      .positive();
  cli.value("--search-radius", &odo.matching.search_radius_px, "PX",
            "window half-size at a feature's level")
      .positive();
}

// -1 to run, else the exit status (usage and errors already printed).
int parseCommandLine(int argc, char** argv, VoArgs* a) {
  evermap::CommandLine cli(
      "evermap-vo-run",
      "Visual odometry over an LCM log, in one process; writes the trajectory (TUM).");
  cli.positional(&a->positional, "LOG TRAJECTORY.tum",
                 "the LCM log with STEREO_CALIB and STEREO (evermap-euroc2lcm output) or RGBD "
                 "(evermap-tum2lcm); the TUM file of the tracked frames");
  cli.flag("--body", &a->options.body_frame, "body (IMU) frame poses instead of the left camera's");
  cli.value("--stats", &a->stats, "FILE.csv", "per-frame statistics");
  cli.value("--output-log", &a->output_log, "FILE",
            "the VO_DELTA and KEYFRAME messages, as an LCM log");
  cli.value("--max-frames", &a->options.max_frames, "N", "stop after N stereo frames").min(1);
  declareOdometryOptions(cli, a);
  cli.flag("--no-motion-prior", &a->no_motion_prior,
           "predict the rotation only (FOVIS), not a constant velocity");
  cli.flag("--no-descriptors", &a->no_descriptors, "no ORB descriptors at keyframes");
  cli.flag("--verbose", &a->verbose,
           "one line per frame that failed, was bridged or retried, with its reason");
  if (const int code = cli.parseOrExit(argc, argv); code >= 0) return code;
  if (!std::isnan(a->disparity_offset_px)) a->options.disparity_offset_px = a->disparity_offset_px;
  if (a->no_descriptors) a->options.pipeline.odometry.keyframe_descriptors = false;
  if (a->no_motion_prior) a->options.pipeline.odometry.constant_velocity = false;
  a->options.output_log = a->output_log;
  if (a->positional.size() != 2) {
    std::fprintf(stderr,
                 "evermap-vo-run: expected LOG and TRAJECTORY.tum, got %zu words (--help)\n",
                 a->positional.size());
    return 2;
  }
  return -1;
}

}  // namespace

int main(int argc, char** argv) {
  VoArgs a;
  if (const int code = parseCommandLine(argc, argv, &a); code >= 0) return code;
  const auto summary = evermap::vo::runOffline(a.positional[0], a.options);
  if (!summary) {
    std::fprintf(stderr, "evermap-vo-run: %s\n", summary.error().message.c_str());
    return 1;
  }
  if (a.verbose) std::printf("%s", summary->verboseReport().c_str());
  if (summary->trajectory.empty()) {
    std::fprintf(stderr, "evermap-vo-run: no frame was tracked\n%s\n", summary->report().c_str());
    return 1;
  }
  if (auto s = evermap::eval::writeTum(summary->trajectory, a.positional[1]); !s) {
    std::fprintf(stderr, "evermap-vo-run: %s\n", s.error().message.c_str());
    return 1;
  }
  if (!a.stats.empty()) {
    if (auto s = evermap::vo::writeFrameStatsCsv(summary->frames, a.stats); !s) {
      std::fprintf(stderr, "evermap-vo-run: %s\n", s.error().message.c_str());
      return 1;
    }
  }
  std::printf("%s\nwrote %s\n", summary->report().c_str(), a.positional[1].c_str());
  return 0;
}
