// evermap-eval: compares an estimated trajectory with ground truth (DESIGN.md section 10).
// Reads TUM, KITTI or EuRoC files, associates by time stamp, aligns (Umeyama SE(3)/Sim(3) or
// none), prints ATE, RPE and optionally the KITTI drift, and writes JSON and a top-view plot.
// Exit status: 0 done, 1 bad input (the message names it), 2 bad command line.

#include <charconv>
#include <cstdio>
#include <cstring>
#include <optional>
#include <string>

#include "core/eval/evaluation.h"
#include "core/common/number_text.h"
#include "core/eval/plot.h"
#include "core/eval/report.h"

namespace {

using namespace evermap;
using namespace evermap::eval;

constexpr const char* kUsage =
    "usage: evermap-eval --gt FILE --est FILE [options]\n"
    "  --gt-format, --est-format tum|kitti|euroc   (default: guessed from extension/content)\n"
    "  --gt-times FILE, --est-times FILE   stamps for a KITTI pose file (default: line index,\n"
    "                                      in seconds)\n"
    "  --align se3|sim3|first|none   Umeyama alignment of the estimate (default se3); first:\n"
    "                          put the first estimated pose on the first ground-truth pose\n"
    "  --max-dt S              largest stamp difference of a pair, seconds (default 0.02)\n"
    "  --rpe-frames N | --rpe-distance M   RPE step (default 1 frame)\n"
    "  --kitti-drift           KITTI devkit drift over 100..800 m segments\n"
    "  --json OUT.json         write the figures as JSON\n"
    "  --plot OUT.png|OUT.svg  top view of ground truth and aligned estimate\n"
    "  --plot-plane auto|xy|xz|yz   plane of the top view (default auto)\n";

struct CommandLine {
  std::string gt, est, gt_times, est_times, json, plot;
  std::optional<TrajectoryFormat> gt_format, est_format;
  PlotPlane plane = PlotPlane::kAuto;
  EvaluationOptions options;
};

bool parseDouble(const std::string& s, double* out) {
  auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), *out);
  return ec == std::errc() && p == s.data() + s.size();
}

bool parseInt(const std::string& s, int* out) {
  auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), *out);
  return ec == std::errc() && p == s.data() + s.size();
}

// Parses argv; on a usage error prints it and returns nullopt.
std::optional<CommandLine> parse(int argc, char** argv) {
  CommandLine c;
  bool rpe_frames = false, rpe_distance = false;
  auto fail = [](const std::string& why) {
    std::fprintf(stderr, "evermap-eval: %s\n%s", why.c_str(), kUsage);
    return std::nullopt;
  };
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      std::fputs(kUsage, stdout);
      std::exit(0);
    }
    if (a == "--kitti-drift") {
      c.options.kitti_drift = true;
      continue;
    }
    if (i + 1 >= argc) return fail(a + " needs a value");
    const std::string v = argv[++i];
    if (a == "--gt") {
      c.gt = v;
    } else if (a == "--est") {
      c.est = v;
    } else if (a == "--gt-times") {
      c.gt_times = v;
    } else if (a == "--est-times") {
      c.est_times = v;
    } else if (a == "--json") {
      c.json = v;
    } else if (a == "--plot") {
      c.plot = v;
    } else if (a == "--gt-format" || a == "--est-format") {
      auto f = parseTrajectoryFormat(v);
      if (!f) return fail(f.error().message);
      (a == "--gt-format" ? c.gt_format : c.est_format) = *f;
    } else if (a == "--align") {
      auto m = parseAlignmentMode(v);
      if (!m) return fail(m.error().message);
      c.options.alignment = *m;
    } else if (a == "--plot-plane") {
      auto p = parsePlotPlane(v);
      if (!p) return fail(p.error().message);
      c.plane = *p;
    } else if (a == "--max-dt") {
      if (!parseDouble(v, &c.options.association.max_dt_s)) return fail("bad --max-dt " + v);
    } else if (a == "--rpe-frames") {
      if (!parseInt(v, &c.options.rpe.delta_frames)) return fail("bad --rpe-frames " + v);
      rpe_frames = true;
    } else if (a == "--rpe-distance") {
      if (!parseDouble(v, &c.options.rpe.delta_distance_m)) return fail("bad --rpe-distance " + v);
      c.options.rpe.delta_frames = 0;
      rpe_distance = true;
    } else {
      return fail("unknown option " + a);
    }
  }
  if (c.gt.empty() || c.est.empty()) return fail("--gt and --est are required");
  if (rpe_frames && rpe_distance) return fail("give --rpe-frames or --rpe-distance, not both");
  if (Status s = c.options.validate(); !s) return fail(s.error().message);
  return c;
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

}  // namespace

int main(int argc, char** argv) {
  const auto cl = parse(argc, argv);
  if (!cl) return 2;
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
  auto report = evaluate(*gt, *est, cl->options);
  if (!report) {
    std::fprintf(stderr, "evermap-eval: %s\n", report.error().message.c_str());
    return 1;
  }
  report->gt_format = gt_format;
  report->est_format = est_format;
  std::fputs(formatText(*report).c_str(), stdout);

  if (!cl->json.empty()) {
    if (Status s = writeJson(*report, cl->json); !s) {
      std::fprintf(stderr, "evermap-eval: %s\n", s.error().message.c_str());
      return 1;
    }
    std::printf("wrote %s\n", cl->json.c_str());
  }
  if (!cl->plot.empty()) {
    TopViewOptions plot;
    plot.plane = cl->plane;
    plot.gt_label = "ground truth: " + std::filesystem::path(cl->gt).filename().string();
    plot.est_label = "estimate" +
                     (cl->options.alignment == AlignmentMode::kNone
                          ? std::string()
                          : std::string(", ") + toString(cl->options.alignment) + "-aligned") +
                     ": " + std::filesystem::path(cl->est).filename().string();
    plot.title = "Top view, alignment: " + std::string(toString(cl->options.alignment));
    const RpeOptions& rpe = cl->options.rpe;
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
