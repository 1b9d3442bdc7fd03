#include "tools/datasets/convert_program.h"

#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include "core/common/command_line.h"
#include "tools/datasets/to_lcm.h"

namespace evermap::datasets {

int convertMain(Dataset dataset, int argc, char** argv) {
  const bool euroc = dataset == Dataset::kEuroc;
  const bool tum = dataset == Dataset::kTumRgbd;
  const std::string program = euroc ? "evermap-euroc2lcm"
                              : tum ? "evermap-tum2lcm"
                                    : "evermap-kitti2lcm";
  CommandLine cli(program,
                  euroc ? "Converts an EuRoC ASL folder to an LCM log."
                  : tum ? "Converts a TUM RGB-D sequence to an LCM log (RGBD, ACCEL, GROUND_TRUTH)."
                        : "Converts a KITTI odometry sequence to an LCM log.");
  std::vector<std::string> positional;
  bool raw = false;
  std::string ground_truth, left, right;
  KittiToLcmOptions kitti;
  TumToLcmOptions tum_options;
  cli.positional(
      &positional, euroc ? "ASL_FOLDER OUTPUT.lcmlog" : "SEQUENCE_FOLDER OUTPUT.lcmlog",
      euroc ? "the folder holding mav0/ (cam0, cam1, imu0, sensor.yaml files), and the log to write"
      : tum ? "a TUM RGB-D sequence (rgb.txt, depth.txt, rgb/, depth/; groundtruth.txt and "
              "accelerometer.txt when present), and the log to write"
            : "a KITTI odometry sequence (image_0/ or image_l/, image_1/ or image_r/, calib.txt, "
              "times.txt or --rate), and the log to write");
  cli.flag("--raw", &raw,
           tum ? "store raw gray8 and raw uint16 depth instead of PNG"
               : "store images as raw gray8 instead of PNG");
  if (tum) {
    cli.value("--camera", &tum_options.calibration, "NAME",
              "freiburg1, freiburg2, freiburg3 or ros-default (TUM's published intrinsics); "
              "default from the folder name (freiburgN or frN), else ros-default");
    cli.value("--max-difference", &tum_options.sequence.max_difference_s, "S",
              "color/depth association limit, seconds (TUM associate.py: 0.02)")
        .positive();
  } else if (euroc) {
    cli.value("--gt", &ground_truth, "FILE",
              "ground truth (EuRoC csv or TUM txt) when mav0/state_groundtruth_estimate0/data.csv "
              "is absent");
  } else {
    cli.value("--poses", &ground_truth, "FILE",
              "ground-truth poses (KITTI format); default SEQUENCE_FOLDER/poses.txt when present");
    cli.value("--rate", &kitti.sequence.rate_hz, "HZ",
              "frame i at i/HZ s instead of times.txt (for copies without it; KITTI: about 10)")
        .positive()
        .max(10000);
    cli.value("--left", &left, "DIR", "left images (default image_0/, else image_l/)");
    cli.value("--right", &right, "DIR", "right images (default image_1/, else image_r/)");
    cli.value("--disparity-offset", &kitti.disparity_offset_px, "PX",
              "the images' disparity offset against calib.txt, written into STEREO_CALIB as the "
              "right camera's "
              "cx = left cx + PX (kitti-stereo-clip: 0.8, from evermap-stereo-check --self-offset; "
              "default 0)")
        .min(-1000)
        .max(1000);
  }
  if (const int code = cli.parseOrExit(argc, argv); code >= 0) return code;
  if (positional.size() != 2) {
    std::fprintf(stderr,
                 "%s: expected the input folder and OUTPUT.lcmlog, got %zu words (--help)\n",
                 program.c_str(), positional.size());
    return 2;
  }
  const auto encoding = raw ? messages::ImageEncoding::kGray8 : messages::ImageEncoding::kPng;
  const auto start = std::chrono::steady_clock::now();  // for the report only
  Expected<ConversionSummary> summary = Error{""};
  if (tum) {
    tum_options.encoding = encoding;
    const std::string name = tum_options.calibration.empty() ? tumCalibrationNameFor(positional[0])
                                                             : tum_options.calibration;
    std::printf("camera: TUM %s\n", name.c_str());
    summary = convertTumRgbdToLcm(positional[0], positional[1], tum_options);
  } else if (euroc) {
    EurocToLcmOptions options;
    options.encoding = encoding;
    options.ground_truth = ground_truth;
    summary = convertEurocToLcm(positional[0], positional[1], options);
  } else {
    kitti.encoding = encoding;
    kitti.sequence.poses = ground_truth;
    kitti.sequence.left_folder = left;
    kitti.sequence.right_folder = right;
    summary = convertKittiToLcm(positional[0], positional[1], kitti);
  }
  if (!summary) {
    std::fprintf(stderr, "%s: %s\n", program.c_str(), summary.error().message.c_str());
    return 1;
  }
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("wrote %s (images: %s)\n%sconverted in %.1f s\n", positional[1].c_str(),
              messages::toString(encoding), summary->report().c_str(), s);
  return 0;
}

}  // namespace evermap::datasets
