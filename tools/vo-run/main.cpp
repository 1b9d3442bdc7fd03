// evermap-vo-run: visual odometry over an LCM log (e.g. from evermap-euroc2lcm), in one
// process, deterministically (tools/vo-run/offline_runner.h). Writes the trajectory in TUM format
// and per-frame statistics as CSV.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "core/common/command_line.h"
#include "core/common/option_fields.h"
#include "tools/vo-run/offline_runner.h"

namespace {

// The runner's settings that the command line reaches, keys named after its flags (--help
// lists them with their defaults, --print-config prints them).
struct VoRunOptions {
  evermap::vo::OfflineOptions offline;

  void declareOptions(evermap::OptionList& o) {
    auto& odo = offline.pipeline.odometry;
    auto& motion = odo.registration.motion;
    o.add("body_frame", &offline.body_frame, "body (IMU) frame poses instead of the left camera's");
    o.add("keyframe_inliers", &odo.keyframe_inlier_threshold, "",
          "new reference below this many inliers (a keyframe only after keyframe_distance or "
          "keyframe_angle)")
        .min(0);
    o.add("keyframe_distance", &odo.keyframe_min_translation_m, "m",
          "a new reference is a map keyframe after moving this far (or keyframe_angle)")
        .min(0);
    o.add("keyframe_angle", &odo.keyframe_min_rotation_rad, "rad",
          "... or after turning this far since the last keyframe")
        .in(0, 3.15);
    o.add("disparity_sigma", &odo.registration.disparity_sigma_px, "px",
          "disparity noise the clique allows for along the rays (0: fixed threshold)")
        .min(0);
    o.add("motion_disparity_sigma", &motion.disparity_sigma_px, "px",
          "disparity noise the motion estimate whitens its residuals for (0: points exact)")
        .min(0);
    o.add("inlier_px", &motion.inlier_max_reprojection_px, "px",
          "stereo: largest reprojection error of an inlier of the motion estimate")
        .positive();
    o.add("max_mean_px", &motion.max_mean_reprojection_px, "px",
          "stereo: largest mean reprojection error of an accepted motion")
        .positive();
    o.add("rgbd_inlier_px", &offline.pipeline.rgbd_inlier_max_reprojection_px, "px",
          "RGB-D: largest reprojection error of an inlier")
        .positive();
    o.add("rgbd_max_mean_px", &offline.pipeline.rgbd_max_mean_reprojection_px, "px",
          "RGB-D: largest mean reprojection error of an accepted motion")
        .positive();
    o.add("rgbd_fast_motion", &offline.pipeline.rgbd_fast_motion_fraction, "",
          "RGB-D: a frame failing at fast rotation is retried with bounds widened to this "
          "fraction of its predicted image motion (0: off)")
        .nonNegative();
    o.add("depth_spread", &odo.features.rgbd.max_relative_spread, "",
          "RGB-D: refuse a corner whose 5x5 depths spread by more than this fraction of its depth")
        .positive();
    o.add("depth_noise", &offline.pipeline.rgbd.depth_noise_per_m2, "1/m",
          "RGB-D: depth noise sigma_z = k z^2 (Khoshelham & Elberink 2012)")
        .positive();
    o.add("clique_threshold", &odo.registration.clique.threshold_m, "m",
          "change of a pairwise distance always consistent")
        .positive();
    o.add("search_radius", &odo.matching.search_radius_px, "px",
          "window half-size at a feature's level")
        .positive();
    o.add("constant_velocity", &odo.constant_velocity,
          "predict a constant velocity (else the rotation only, as FOVIS)");
    o.add("keyframe_descriptors", &odo.keyframe_descriptors, "ORB descriptors at keyframes");
    o.add("self_calibrate", &odo.self_calibrate,
          "stereo: estimate the disparity offset from the images and apply it (docs/vo.md)");
    o.add("startup_hold_s", &offline.pipeline.startup_hold_s, "s",
          "stereo: the first frames held for self-calibration's first decision and processed "
          "again with its correction (0: off)")
        .nonNegative();
    o.add("line_delay_us", &odo.line_delay_us, "us",
          "rolling shutter: the camera's line delay the features are corrected with (0: a "
          "global shutter; docs/rgbd.md)")
        .nonNegative();
  }
};

// The command line of a run, beside the runner's options.
struct VoArgs {
  VoRunOptions run;
  std::string stats, output_log;
  std::vector<std::string> positional;
  bool verbose = false;
  bool calibrate_line_delay = false;
  double disparity_offset_px = std::nan("");
};

// -1 to run, else the exit status (usage and errors already printed).
int parseCommandLine(int argc, char** argv, VoArgs* a) {
  evermap::CommandLine cli(
      "evermap-vo-run",
      "Visual odometry over an LCM log, in one process; writes the trajectory (TUM).");
  cli.positional(&a->positional, "LOG TRAJECTORY.tum",
                 "the LCM log with STEREO_CALIB and STEREO (evermap-euroc2lcm output) or RGBD "
                 "(evermap-tum2lcm); the TUM file of the tracked frames");
  cli.value("--stats", &a->stats, "FILE.csv", "per-frame statistics");
  cli.value("--output-log", &a->output_log, "FILE",
            "the VO_DELTA and KEYFRAME messages, as an LCM log");
  cli.value("--disparity-offset", &a->disparity_offset_px, "PX",
            "stereo: replaces the calibration's disparity offset (right cx - left cx of a "
            "rectified STEREO_CALIB, added to every measured disparity; evermap-stereo-check "
            "--self-offset estimates it; default: the log's, which evermap-kitti2lcm "
            "--disparity-offset writes)")
      .in(-1000, 1000);
  cli.flag("--verbose", &a->verbose,
           "one line per frame that failed, was bridged or retried, with its reason");
  cli.flag("--calibrate-line-delay", &a->calibrate_line_delay,
           "estimate the camera's rolling-shutter line delay from the images: the odometry run "
           "again, from --line-delay-us, with what its registered pairs say is left, until "
           "nothing significant is; the trajectory is the last run's (docs/rgbd.md)");
  cli.options(&a->run);
  cli.value("--max-frames", &a->run.offline.max_frames, "N", "stop after N stereo frames").min(1);
  for (const char* key : {"keyframe_inliers", "keyframe_distance", "keyframe_angle",
                          "disparity_sigma", "motion_disparity_sigma", "inlier_px", "max_mean_px",
                          "rgbd_inlier_px", "rgbd_max_mean_px", "rgbd_fast_motion", "depth_spread",
                          "depth_noise", "clique_threshold", "search_radius", "line_delay_us"}) {
    std::string flag = std::string("--") + key;
    std::replace(flag.begin(), flag.end(), '_', '-');
    cli.alias(flag, key, "VALUE");
  }
  cli.alias("--body", "body_frame", "");
  cli.alias("--no-motion-prior", "constant_velocity", "", "false");
  cli.alias("--no-descriptors", "keyframe_descriptors", "", "false");
  cli.alias("--no-self-calibration", "self_calibrate", "", "false");
  if (const int code = cli.parseOrExit(argc, argv); code >= 0) return code;
  evermap::vo::OfflineOptions& options = a->run.offline;
  if (!std::isnan(a->disparity_offset_px)) options.disparity_offset_px = a->disparity_offset_px;
  options.output_log = a->output_log;
  if (a->positional.size() != 2) {
    std::fprintf(stderr,
                 "evermap-vo-run: expected LOG and TRAJECTORY.tum, got %zu words (--help)\n",
                 a->positional.size());
    return 2;
  }
  return -1;
}

// The run the command line asks for: one, or the line delay's calibration (its runs printed).
evermap::Expected<evermap::vo::OfflineSummary> run(const VoArgs& a) {
  if (!a.calibrate_line_delay) return evermap::vo::runOffline(a.positional[0], a.run.offline);
  auto calibration = evermap::vo::calibrateLineDelay(a.positional[0], a.run.offline);
  if (!calibration) return calibration.error();
  for (const std::string& line : calibration->runs) std::printf("%s\n", line.c_str());
  std::printf("line delay: %.1f us per row, +- %.1f us (the last run's jackknife)\n",
              calibration->line_delay_us, calibration->standard_error_us);
  return std::move(calibration->summary);
}

}  // namespace

int main(int argc, char** argv) {
  VoArgs a;
  if (const int code = parseCommandLine(argc, argv, &a); code >= 0) return code;
  const auto summary = run(a);
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
