// evermap-place-eval: runs the bag-of-words loop detector (tools/place-eval/loop_evaluation.h) over
// a monocular image sequence with a loop ground-truth matrix and prints the precision-recall curve
// of the raw scores and of the scores after the epipolar check, and the figures at the chosen
// thresholds. Exit status: 0 done, 1 bad input (the message names it), 2 bad command line.

#include <cstdio>
#include <cstdlib>
#include <optional>
#include <string>
#include <vector>

#include "core/bow/vocabulary_io.h"
#include "core/common/atomic_write.h"
#include "core/common/command_line.h"
#include "core/common/option_fields.h"
#include "tools/place-eval/loop_evaluation.h"
#include "tools/vocab-train/image_training.h"

namespace {

using namespace evermap;
using namespace evermap::bow;

// The evaluation's settings (--help lists them, --print-config prints them).
struct PlaceEvalOptions {
  SequenceOptions sequence;
  double raw_threshold = kDefaultRawThreshold;
  double geo_threshold = kDefaultGeometricThreshold;

  void declareOptions(OptionList& o) {
    o.add("exclude_recent", &sequence.exclude_recent, "", "most recent images not searched").min(0);
    o.add("candidates", &sequence.candidates, "", "candidates per query for the geometric check")
        .min(1);
    o.add("min_inliers", &sequence.geometry.min_inliers, "", "epipolar RANSAC inliers to accept")
        .min(0);
    o.add("raw_threshold", &raw_threshold, "", "operating threshold of the raw score").min(0);
    o.add("geo_threshold", &geo_threshold, "", "operating threshold of the score after the check")
        .min(0);
    o.nest("", &sequence.orb);
    o.add("direct_depth", &sequence.direct_index_depth, "",
          "direct-index depth for guided matching")
        .min(0);
    o.add("ratio", &sequence.geometry.matching.ratio, "", "ratio test of guided matching (1: off)")
        .positive()
        .max(1);
    o.add("max_distance", &sequence.geometry.matching.max_distance, "",
          "largest Hamming distance of a match")
        .in(0, 256);
    o.add("ransac_px", &sequence.geometry.ransac_threshold_px, "px", "epipolar RANSAC threshold")
        .positive();
  }
};

struct Command {
  std::string images, gt, vocab, train_root, csv;
  bool full_curve = false;
  PlaceEvalOptions tool;
};

// Returns -1 to run, or main's exit status.
int parse(int argc, char** argv, Command* c) {
  CommandLine cli("evermap-place-eval",
                  "Loop-detection precision-recall over an image sequence with a loop matrix.");
  cli.value("--images", &c->images, "DIR", "the image sequence", /*required=*/true);
  cli.value("--gt", &c->gt, "MATRIX.bmp", "loop ground-truth matrix", /*required=*/true);
  cli.value("--vocab", &c->vocab, "FILE", "evermap (.evoc) or DBoW2/DBoW3 (.yml.gz) vocabulary");
  cli.value("--train-default", &c->train_root, "DIR",
            "train the default vocabulary from the shared data under DIR (k=10, L=5)");
  cli.options(&c->tool);
  cli.alias("--exclude-recent", "exclude_recent", "N");
  cli.alias("--candidates", "candidates", "N");
  cli.alias("--min-inliers", "min_inliers", "N");
  cli.alias("--raw-threshold", "raw_threshold", "S");
  cli.alias("--geo-threshold", "geo_threshold", "S");
  cli.alias("--features", "features", "N");
  cli.alias("--direct-depth", "direct_depth", "N");
  cli.alias("--ratio", "ratio", "R");
  cli.alias("--max-distance", "max_distance", "N");
  cli.alias("--ransac-px", "ransac_px", "P");
  cli.value("--csv", &c->csv, "FILE", "write every query's candidates as CSV");
  cli.flag("--full-curve", &c->full_curve, "print every point of the curves, not a summary");
  if (const int code = cli.parseOrExit(argc, argv); code >= 0) return code;
  auto fail = [&](const std::string& why) {
    std::fprintf(stderr, "evermap-place-eval: %s\n%s", why.c_str(), cli.usage().c_str());
    return 2;
  };
  if (c->vocab.empty() == c->train_root.empty()) {
    return fail("give exactly one of --vocab and --train-default");
  }
  if (std::string why = c->tool.sequence.validate(); !why.empty()) return fail(why);
  return -1;
}

const char* name(Decision d) { return d == Decision::kRawScore ? "raw score" : "score + epipolar"; }

void printCurve(const PrCurve& curve, bool full) {
  std::printf("\nprecision-recall, %s (%zu queries with a loop)\n", name(curve.decision),
              curve.queries_with_loop);
  std::printf("  threshold   TP   FP  precision  recall\n");
  // Without --full-curve: a point whenever the false positives change or the recall has
  // dropped by 5 points since the last printed one, and the last point.
  const PrPoint* printed = nullptr;
  for (size_t k = 0; k < curve.points.size(); ++k) {
    const PrPoint& p = curve.points[k];
    const bool show = full || !printed || k + 1 == curve.points.size() ||
                      p.false_positives != printed->false_positives ||
                      printed->recall - p.recall >= 0.05 - 1e-12;
    if (!show) continue;
    std::printf("  %9.4f %4d %4d  %8.1f%%  %5.1f%%\n", p.threshold, p.true_positives,
                p.false_positives, 100 * p.precision, 100 * p.recall);
    printed = &p;
  }
  const PrPoint& b = curve.best_at_full_precision;
  std::printf("  best recall at 100%% precision: %.1f%% (%d of %zu) from threshold %.4f\n",
              100 * b.recall, b.true_positives, curve.queries_with_loop, b.threshold);
}

// --csv: every query's candidates, images numbered from 1.
Status writeCandidatesCsv(const std::string& file, const std::vector<QueryRecord>& records,
                          const LoopGroundTruth& gt) {
  std::string csv = "query,rank,candidate,score,matches,inliers,geometric_ok,ground_truth\n";
  for (const QueryRecord& r : records) {
    for (size_t k = 0; k < r.candidates.size(); ++k) {
      const CandidateRecord& c = r.candidates[k];
      char line[160];
      std::snprintf(line, sizeof(line), "%zu,%zu,%zu,%.6f,%d,%d,%d,%d\n", r.image + 1, k + 1,
                    c.image + 1, c.score, c.matches, c.inliers, c.geometric_ok ? 1 : 0,
                    gt.loop(r.image, c.image) ? 1 : 0);
      csv += line;
    }
  }
  return writeFileAtomically(file, csv);
}

}  // namespace

int main(int argc, char** argv) {
  Command command;
  if (const int code = parse(argc, argv, &command); code >= 0) return code;
  const Command* cmd = &command;
  auto fail = [](const std::string& m) {
    std::fprintf(stderr, "evermap-place-eval: %s\n", m.c_str());
    return 1;
  };
  auto images = listImages(cmd->images);
  if (!images) return fail(images.error().message);
  auto gt = LoopGroundTruth::fromImage(cmd->gt);
  if (!gt) return fail(gt.error().message);
  if (gt->size() != images->size()) {
    return fail(cmd->gt + ": a " + std::to_string(gt->size()) + "x" + std::to_string(gt->size()) +
                " matrix for " + std::to_string(images->size()) + " images in " + cmd->images);
  }
  std::optional<Vocabulary> vocabulary;
  if (!cmd->vocab.empty()) {
    auto v = loadAnyVocabulary(cmd->vocab);
    if (!v) return fail(v.error().message);
    vocabulary = std::move(*v);
    std::printf("vocabulary %s: k=%d L=%d, %zu words\n", cmd->vocab.c_str(),
                vocabulary->branching(), vocabulary->levels(), vocabulary->numWords());
  } else {
    ImageTrainingSummary summary;
    auto v = trainFromImageFolders(defaultTrainingFolders(cmd->train_root), {}, &summary);
    if (!v) return fail(v.error().message);
    vocabulary = std::move(*v);
    std::printf("default vocabulary: %s\n", summary.message.c_str());
  }
  std::printf("%zu images, ground truth %zu positive cells; recent-frame exclusion %d images\n",
              images->size(), gt->numCells(), cmd->tool.sequence.exclude_recent);

  auto records = runLoopDetector(*images, *vocabulary, cmd->tool.sequence);
  if (!records) return fail(records.error().message);

  for (Decision d : {Decision::kRawScore, Decision::kGeometricCheck}) {
    printCurve(precisionRecall(*records, *gt, d, cmd->tool.sequence.exclude_recent),
               cmd->full_curve);
  }
  // The other threshold of the check: inliers, at the chosen score threshold.
  std::printf("\nscore + epipolar at score >= %.3f, by inlier threshold\n",
              cmd->tool.geo_threshold);
  std::printf("  inliers   TP   FP  precision  recall\n");
  for (int m : {8, 10, 12, 15, 20, 25, 30, 40, 50, 60, 80, 100}) {
    const PrPoint p = evaluateAt(*records, *gt, Decision::kGeometricCheck,
                                 cmd->tool.sequence.exclude_recent, cmd->tool.geo_threshold, m);
    std::printf("  %7d %4d %4d  %8.1f%%  %5.1f%%\n", m, p.true_positives, p.false_positives,
                100 * p.precision, 100 * p.recall);
  }
  std::printf("\nat the chosen thresholds:\n");
  const PrPoint raw = evaluateAt(*records, *gt, Decision::kRawScore,
                                 cmd->tool.sequence.exclude_recent, cmd->tool.raw_threshold);
  const PrPoint geo = evaluateAt(*records, *gt, Decision::kGeometricCheck,
                                 cmd->tool.sequence.exclude_recent, cmd->tool.geo_threshold);
  std::printf("  raw score        >= %.3f: precision %.1f%%, recall %.1f%% (TP %d, FP %d)\n",
              raw.threshold, 100 * raw.precision, 100 * raw.recall, raw.true_positives,
              raw.false_positives);
  std::printf(
      "  score + epipolar >= %.3f, >= %d inliers: precision %.1f%%, recall %.1f%% "
      "(TP %d, FP %d)\n",
      geo.threshold, cmd->tool.sequence.geometry.min_inliers, 100 * geo.precision, 100 * geo.recall,
      geo.true_positives, geo.false_positives);

  if (!cmd->csv.empty()) {
    if (Status s = writeCandidatesCsv(cmd->csv, *records, *gt); !s) return fail(s.error().message);
    std::printf("candidates written to %s (images numbered from 1)\n", cmd->csv.c_str());
  }
  return 0;
}
