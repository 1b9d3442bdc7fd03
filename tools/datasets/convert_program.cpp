#include "tools/datasets/convert_program.h"

#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include "core/common/command_line.h"
#include "core/common/option_fields.h"
#include "tools/datasets/to_lcm.h"

namespace evermap::datasets {

namespace {

// The command line of a converter.
struct ConvertArgs {
  std::vector<std::string> positional;
  bool raw = false;
  messages::ImageEncoding encoding = messages::ImageEncoding::kZstd;
  std::string ground_truth, left, right;
  KittiToLcmOptions kitti;
  TumToLcmOptions tum;
};

// The conversion's settings of one data set (--help lists them, --print-config prints them).
template <Dataset kDataset>
struct ConvertOptions {
  ConvertArgs* a = nullptr;  // where the values live
  ConvertArgs defaults;      // a default-constructed struct points at its own
  ConvertOptions() : a(&defaults) {}
  explicit ConvertOptions(ConvertArgs* args) : a(args) {}

  void declareOptions(OptionList& o) {
    o.choice("encoding", &a->encoding, messages::imageEncodingNames(),
             kDataset == Dataset::kTumRgbd
                 ? "how gray images are stored: zstd rows (decode fastest), png (other tools read "
                   "it) or gray8 (raw); depth is 16-bit PNG, raw uint16 with gray8"
                 : "how images are stored: zstd rows (decode fastest), png (other tools read it) "
                   "or gray8 (raw)");
    o.add("raw", &a->raw, "same as encoding = gray8");
    if (kDataset == Dataset::kTumRgbd) {
      o.add("camera", &a->tum.calibration, "",
            "freiburg1, freiburg2, freiburg3 or ros-default (TUM's published intrinsics); empty: "
            "from the folder name (freiburgN or frN), else ros-default");
      o.add("max_difference_s", &a->tum.sequence.max_difference_s, "s",
            "color/depth association limit (TUM associate.py: 0.02)")
          .positive();
    }
    if (kDataset == Dataset::kKitti) {
      o.add("disparity_offset_px", &a->kitti.disparity_offset_px, "px",
            "the images' disparity offset against calib.txt, written into STEREO_CALIB as the "
            "right camera's cx = left cx + this (kitti-stereo-clip: 0.8, from evermap-stereo-check "
            "--self-offset)")
          .in(-1000, 1000);
    }
  }
};

// The options only one data set has.
void declareDatasetOptions(Dataset dataset, CommandLine& cli, ConvertArgs* a) {
  if (dataset == Dataset::kTumRgbd) {
    ConvertOptions<Dataset::kTumRgbd> view(a);  // the list points into *a
    cli.options(&view);
    cli.alias("--camera", "camera", "NAME");
    cli.alias("--max-difference", "max_difference_s", "S");
  } else if (dataset == Dataset::kEuroc) {
    ConvertOptions<Dataset::kEuroc> view(a);  // the list points into *a
    cli.options(&view);
    cli.value("--gt", &a->ground_truth, "FILE",
              "ground truth (EuRoC csv or TUM txt) when mav0/state_groundtruth_estimate0/data.csv "
              "is absent");
  } else {
    ConvertOptions<Dataset::kKitti> view(a);  // the list points into *a
    cli.options(&view);
    cli.value("--poses", &a->ground_truth, "FILE",
              "ground-truth poses (KITTI format); default SEQUENCE_FOLDER/poses.txt when present");
    cli.value("--rate", &a->kitti.sequence.rate_hz, "HZ",
              "frame i at i/HZ s instead of times.txt (for copies without it; KITTI: about 10)")
        .positive()
        .max(10000);
    cli.value("--left", &a->left, "DIR", "left images (default image_0/, else image_l/)");
    cli.value("--right", &a->right, "DIR", "right images (default image_1/, else image_r/)");
    cli.alias("--disparity-offset", "disparity_offset_px", "PX");
  }
  cli.alias("--raw", "raw", "");
  cli.alias("--encoding", "encoding", "zstd|png|gray8");
}

// -1 to run, else the exit status (usage and errors already printed).
int parseCommandLine(Dataset dataset, const std::string& program, int argc, char** argv,
                     ConvertArgs* a) {
  const bool euroc = dataset == Dataset::kEuroc;
  const bool tum = dataset == Dataset::kTumRgbd;
  CommandLine cli(program,
                  euroc ? "Converts an EuRoC ASL folder to an LCM log."
                  : tum ? "Converts a TUM RGB-D sequence to an LCM log (RGBD, ACCEL, GROUND_TRUTH)."
                        : "Converts a KITTI odometry sequence to an LCM log.");
  cli.positional(
      &a->positional, euroc ? "ASL_FOLDER OUTPUT.lcmlog" : "SEQUENCE_FOLDER OUTPUT.lcmlog",
      euroc ? "the folder holding mav0/ (cam0, cam1, imu0, sensor.yaml files), and the log to write"
      : tum ? "a TUM RGB-D sequence (rgb.txt, depth.txt, rgb/, depth/; groundtruth.txt and "
              "accelerometer.txt when present), and the log to write"
            : "a KITTI odometry sequence (image_0/ or image_l/, image_1/ or image_r/, calib.txt, "
              "times.txt or --rate), and the log to write");
  declareDatasetOptions(dataset, cli, a);
  if (const int code = cli.parseOrExit(argc, argv); code >= 0) return code;
  if (a->positional.size() != 2) {
    std::fprintf(stderr,
                 "%s: expected the input folder and OUTPUT.lcmlog, got %zu words (--help)\n",
                 program.c_str(), a->positional.size());
    return 2;
  }
  return -1;
}

// The conversion itself, by data set.
Expected<ConversionSummary> convert(Dataset dataset, ConvertArgs& a,
                                    messages::ImageEncoding encoding) {
  const std::string& in = a.positional[0];
  const std::string& out = a.positional[1];
  if (dataset == Dataset::kTumRgbd) {
    a.tum.encoding = encoding;
    const std::string name =
        a.tum.calibration.empty() ? tumCalibrationNameFor(in) : a.tum.calibration;
    std::printf("camera: TUM %s\n", name.c_str());
    return convertTumRgbdToLcm(in, out, a.tum);
  }
  if (dataset == Dataset::kEuroc) {
    EurocToLcmOptions options;
    options.encoding = encoding;
    options.ground_truth = a.ground_truth;
    return convertEurocToLcm(in, out, options);
  }
  a.kitti.encoding = encoding;
  a.kitti.sequence.poses = a.ground_truth;
  a.kitti.sequence.left_folder = a.left;
  a.kitti.sequence.right_folder = a.right;
  return convertKittiToLcm(in, out, a.kitti);
}

}  // namespace

int convertMain(Dataset dataset, int argc, char** argv) {
  const std::string program = dataset == Dataset::kEuroc     ? "evermap-euroc2lcm"
                              : dataset == Dataset::kTumRgbd ? "evermap-tum2lcm"
                                                             : "evermap-kitti2lcm";
  ConvertArgs a;
  if (const int code = parseCommandLine(dataset, program, argc, argv, &a); code >= 0) return code;
  const auto encoding = a.raw ? messages::ImageEncoding::kGray8 : a.encoding;
  const auto start = std::chrono::steady_clock::now();  // for the report only
  const Expected<ConversionSummary> summary = convert(dataset, a, encoding);
  if (!summary) {
    std::fprintf(stderr, "%s: %s\n", program.c_str(), summary.error().message.c_str());
    return 1;
  }
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("wrote %s (images: %s)\n%sconverted in %.1f s\n", a.positional[1].c_str(),
              messages::toString(encoding), summary->report().c_str(), s);
  return 0;
}

}  // namespace evermap::datasets
