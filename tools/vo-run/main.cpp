// evermap-vo-run: visual odometry over an LCM log (e.g. from evermap-euroc2lcm), in one
// process, deterministically (tools/vo-run/offline_runner.h). Writes the trajectory in TUM format
// and per-frame statistics as CSV.
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "core/common/command_line.h"
#include "tools/vo-run/offline_runner.h"

int main(int argc, char** argv) {
  evermap::vo::OfflineOptions options;
  std::string stats, output_log;
  std::vector<std::string> positional;
  bool no_descriptors = false, verbose = false, no_motion_prior = false;
  evermap::CommandLine cli(
      "evermap-vo-run",
      "Visual odometry over an LCM log, in one process; writes the trajectory (TUM).");
  cli.positional(&positional, "LOG TRAJECTORY.tum",
                 "the LCM log with STEREO_CALIB and STEREO (evermap-euroc2lcm output) or RGBD "
                 "(evermap-tum2lcm); the TUM file of the tracked frames");
  cli.flag("--body", &options.body_frame, "body (IMU) frame poses instead of the left camera's");
  cli.value("--stats", &stats, "FILE.csv", "per-frame statistics");
  cli.value("--output-log", &output_log, "FILE",
            "the VO_DELTA and KEYFRAME messages, as an LCM log");
  cli.value("--max-frames", &options.max_frames, "N", "stop after N stereo frames").min(1);
  cli.value("--keyframe-inliers", &options.pipeline.odometry.keyframe_inlier_threshold, "N",
            "new reference below N inliers (default 150; a keyframe only after "
            "--keyframe-distance/--keyframe-angle)")
      .min(0);
  auto& odo = options.pipeline.odometry;
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
  double disparity_offset_px = std::nan("");
  cli.value("--disparity-offset", &disparity_offset_px, "PX",
            "stereo: replaces the calibration's disparity offset (right cx - left cx of a "
            "rectified STEREO_CALIB, "
            "added to every measured disparity; evermap-stereo-check --self-offset estimates it; "
            "default: the log's, "
            "which evermap-kitti2lcm --disparity-offset writes)")
      .min(-1000)
      .max(1000);
  cli.value("--clique-threshold", &odo.registration.clique.threshold_m, "M",
            "change of a pairwise distance always consistent")
      .positive();
  cli.value("--search-radius", &odo.matching.search_radius_px, "PX",
            "window half-size at a feature's level")
      .positive();
  cli.flag("--no-motion-prior", &no_motion_prior,
           "predict the rotation only (FOVIS), not a constant velocity");
  cli.flag("--no-descriptors", &no_descriptors, "no ORB descriptors at keyframes");
  cli.flag("--verbose", &verbose,
           "one line per frame that failed, was bridged or retried, with its reason");
  if (const int code = cli.parseOrExit(argc, argv); code >= 0) return code;
  if (!std::isnan(disparity_offset_px)) options.disparity_offset_px = disparity_offset_px;
  if (no_descriptors) options.pipeline.odometry.keyframe_descriptors = false;
  if (no_motion_prior) options.pipeline.odometry.constant_velocity = false;
  options.output_log = output_log;
  if (positional.size() != 2) {
    std::fprintf(stderr,
                 "evermap-vo-run: expected LOG and TRAJECTORY.tum, got %zu words (--help)\n",
                 positional.size());
    return 2;
  }
  const auto summary = evermap::vo::runOffline(positional[0], options);
  if (!summary) {
    std::fprintf(stderr, "evermap-vo-run: %s\n", summary.error().message.c_str());
    return 1;
  }
  if (verbose) std::printf("%s", summary->verboseReport().c_str());
  if (summary->trajectory.empty()) {
    std::fprintf(stderr, "evermap-vo-run: no frame was tracked\n%s\n", summary->report().c_str());
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
