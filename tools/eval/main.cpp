// evermap-eval: compares an estimated trajectory with ground truth (DESIGN.md section 10).
// Reads TUM, KITTI or EuRoC files, associates by time stamp, aligns (Umeyama SE(3)/Sim(3) or
// none), prints ATE, RPE and optionally the KITTI drift, and writes JSON and a top-view plot.
// Exit status: 0 done, 1 bad input (the message names it), 2 bad command line.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <optional>
#include <string>

#include "core/common/command_line.h"
#include "core/common/option_fields.h"
#include "core/common/number_text.h"
#include "tools/eval/association.h"
#include "tools/eval/evaluation.h"
#include "tools/eval/plot.h"
#include "tools/eval/report.h"

namespace {

using namespace evermap;
using namespace evermap::eval;

// The evaluation's settings (--help lists them, --print-config prints them).
struct EvalToolOptions {
  EvaluationOptions evaluation;
  PlotPlane plane = PlotPlane::kAuto;

  void declareOptions(OptionList& o) {
    o.choice("align", &evaluation.alignment,
             {{"se3", AlignmentMode::kSE3},
              {"sim3", AlignmentMode::kSim3},
              {"first", AlignmentMode::kFirstPose},
              {"none", AlignmentMode::kNone}},
             "Umeyama alignment of the estimate; first: the first estimated pose on the first "
             "ground-truth pose");
    o.add("max_dt_s", &evaluation.association.max_dt_s, "s", "largest stamp difference of a pair")
        .positive();
    o.add("kitti_drift", &evaluation.kitti_drift, "KITTI devkit drift over 100..800 m segments");
    o.choice("plot_plane", &plane,
             {{"auto", PlotPlane::kAuto},
              {"xy", PlotPlane::kXY},
              {"xz", PlotPlane::kXZ},
              {"yz", PlotPlane::kYZ}},
             "plane of the top view");
  }
};

struct Arguments {
  std::string gt, est, gt_times, est_times, json, plot;
  bool steps = false;
  std::optional<TrajectoryFormat> gt_format, est_format;
  EvalToolOptions tool;
};

// An option value read by `parse` (text -> Expected<T>) into *out.
template <typename T, typename Parse>
std::function<Status(const std::string&)> parsedInto(T* out, Parse parse) {
  return [out, parse](const std::string& v) -> Status {
    auto x = parse(v);
    if (!x) return x.error();
    *out = *x;
    return Ok{};
  };
}

// Parses argv: -1 to run, or the exit status (0 after --help, 2 after a bad command line).
int parse(int argc, char** argv, Arguments* c) {
  evermap::CommandLine cli(
      "evermap-eval", "Compares an estimated trajectory with ground truth: ATE, RPE, KITTI drift.");
  cli.value("--gt", &c->gt, "FILE", "ground truth (TUM, KITTI or EuRoC)", true);
  cli.value("--est", &c->est, "FILE", "the estimate (TUM, KITTI or EuRoC)", true);
  cli.value("--gt-format", parsedInto(&c->gt_format, parseTrajectoryFormat), "tum|kitti|euroc",
            "default: guessed from extension/content");
  cli.value("--est-format", parsedInto(&c->est_format, parseTrajectoryFormat), "tum|kitti|euroc",
            "default: guessed from extension/content");
  cli.value("--gt-times", &c->gt_times, "FILE",
            "stamps for a KITTI pose file (default: line index, in seconds)");
  cli.value("--est-times", &c->est_times, "FILE", "the same for the estimate");
  cli.options(&c->tool);
  cli.alias("--align", "align", "se3|sim3|first|none");
  cli.alias("--max-dt", "max_dt_s", "S");
  // Not given: the sentinels (the command line refuses NaN, and no one types INT_MIN frames).
  int rpe_frames = std::numeric_limits<int>::min();
  double rpe_distance = std::numeric_limits<double>::quiet_NaN();
  cli.value("--rpe-frames", &rpe_frames, "N", "RPE step in frames (default 1)").min(1);
  cli.value("--rpe-distance", &rpe_distance, "M", "RPE step in metres").positive();
  cli.flag("--steps", &c->steps,
           "per-step translation ratio |est step| / |gt step| (median, p10, p90) and the end error "
           "relative to the first pose, "
           "% of the ground-truth path and degrees: a scale error shows in the ratio");
  cli.alias("--kitti-drift", "kitti_drift", "");
  cli.value("--json", &c->json, "OUT.json", "write the figures as JSON");
  cli.value("--plot", &c->plot, "OUT.png|OUT.svg", "top view of ground truth and aligned estimate");
  cli.alias("--plot-plane", "plot_plane", "auto|xy|xz|yz");
  if (const int code = cli.parseOrExit(argc, argv); code >= 0) return code;
  const bool by_frames = rpe_frames != std::numeric_limits<int>::min(),
             by_distance = !std::isnan(rpe_distance);
  if (by_frames) c->tool.evaluation.rpe.delta_frames = rpe_frames;
  if (by_distance) {
    c->tool.evaluation.rpe.delta_frames = 0;
    c->tool.evaluation.rpe.delta_distance_m = rpe_distance;
  }
  std::string bad;
  if (by_frames && by_distance) bad = "give --rpe-frames or --rpe-distance, not both";
  if (Status s = c->tool.evaluation.validate(); bad.empty() && !s) bad = s.error().message;
  if (!bad.empty()) {
    std::fprintf(stderr, "evermap-eval: %s (--help)\n", bad.c_str());
    return 2;
  }
  return -1;
}

Expected<Trajectory> load(const std::string& file, std::optional<TrajectoryFormat> format,
                          const std::string& times, std::string* format_name) {
  if (!format) {
    auto guessed = guessTrajectoryFormat(file);
    if (!guessed) return guessed.error();
    format = *guessed;
  }
  if (!times.empty() && *format != TrajectoryFormat::kKitti) {
    return makeError(times, ": a times file only goes with a KITTI pose file, but ", file, " is ",
                     toString(*format));
  }
  *format_name = toString(*format);
  return readTrajectory(file, *format, times);
}

// --steps: per-step length ratio and end error, both independent of any alignment.
void printSteps(const Trajectory& gt, const Trajectory& est, const AssociationOptions& options) {
  const auto a = associate(gt, est, options);
  if (!a || a->size() < 2) return;
  std::vector<double> ratio;
  double gt_path = 0.0;
  for (size_t k = 1; k < a->size(); ++k) {
    const double g = (a->gt[k - 1].inverse() * a->gt[k]).translation().norm();
    const double e = (a->est[k - 1].inverse() * a->est[k]).translation().norm();
    gt_path += g;
    if (g > 0.05) ratio.push_back(e / g);  // steps of a few centimetres say nothing about scale
  }
  const size_t n = a->size() - 1;
  const core::SE3d gt_rel = a->gt[0].inverse() * a->gt[n],
                   est_rel = a->est[0].inverse() * a->est[n];
  const core::SE3d err = gt_rel.inverse() * est_rel;
  std::sort(ratio.begin(), ratio.end());
  auto q = [&ratio](double f) {
    return ratio.empty() ? std::nan("") : ratio[static_cast<size_t>(f * (ratio.size() - 1) + 0.5)];
  };
  std::printf(
      "steps (%zu of %zu longer than 5 cm)\n  length ratio est/gt  median %.4f   p10 %.4f   p90 "
      "%.4f\n",
      ratio.size(), n, q(0.5), q(0.1), q(0.9));
  std::printf("  end error from the first pose: %.3f m = %.2f %% of %.2f m, %.2f deg\n",
              err.translation().norm(), 100.0 * err.translation().norm() / gt_path, gt_path,
              err.so3().log().norm() * 180.0 / M_PI);
}

}  // namespace

int main(int argc, char** argv) {
  Arguments args;
  if (const int code = parse(argc, argv, &args); code >= 0) return code;
  const Arguments* cl = &args;
  std::string gt_format, est_format;
  const auto gt = load(cl->gt, cl->gt_format, cl->gt_times, &gt_format);
  if (!gt) {
    std::fprintf(stderr, "evermap-eval: %s\n", gt.error().message.c_str());
    return 1;
  }
  const auto est = load(cl->est, cl->est_format, cl->est_times, &est_format);
  if (!est) {
    std::fprintf(stderr, "evermap-eval: %s\n", est.error().message.c_str());
    return 1;
  }
  auto report = evaluate(*gt, *est, cl->tool.evaluation);
  if (!report) {
    std::fprintf(stderr, "evermap-eval: %s\n", report.error().message.c_str());
    return 1;
  }
  report->gt_format = gt_format;
  report->est_format = est_format;
  std::fputs(formatText(*report).c_str(), stdout);
  if (cl->steps) printSteps(*gt, *est, cl->tool.evaluation.association);

  if (!cl->json.empty()) {
    if (Status s = writeJson(*report, cl->json); !s) {
      std::fprintf(stderr, "evermap-eval: %s\n", s.error().message.c_str());
      return 1;
    }
    std::printf("wrote %s\n", cl->json.c_str());
  }
  if (!cl->plot.empty()) {
    TopViewOptions plot;
    plot.plane = cl->tool.plane;
    plot.gt_label = "ground truth: " + std::filesystem::path(cl->gt).filename().string();
    plot.est_label =
        "estimate" +
        (cl->tool.evaluation.alignment == AlignmentMode::kNone
             ? std::string()
             : std::string(", ") + toString(cl->tool.evaluation.alignment) + "-aligned") +
        ": " + std::filesystem::path(cl->est).filename().string();
    plot.title = "Top view, alignment: " + std::string(toString(cl->tool.evaluation.alignment));
    const RpeOptions& rpe = cl->tool.evaluation.rpe;
    const std::string step = rpe.byDistance() ? numberText(rpe.delta_distance_m) + " m"
                                              : std::to_string(rpe.delta_frames) +
                                                    (rpe.delta_frames == 1 ? " frame" : " frames");
    char sub[256];
    std::snprintf(sub, sizeof(sub),
                  "ATE rmse %.4g m (max %.4g m, %zu pairs)   RPE over %s: rmse %.4g m, %.4g deg",
                  report->ate.translation_m.rmse, report->ate.translation_m.max, report->pairs,
                  step.c_str(), report->rpe.translation_m.rmse, report->rpe.rotation_deg.rmse);
    plot.subtitle = sub;
    if (Status s =
            writeTopView(cl->plot, report->gt_positions, report->est_positions_aligned, plot);
        !s) {
      std::fprintf(stderr, "evermap-eval: %s\n", s.error().message.c_str());
      return 1;
    }
    std::printf("wrote %s\n", cl->plot.c_str());
  }
  return 0;
}
