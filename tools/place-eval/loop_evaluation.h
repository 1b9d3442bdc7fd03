#pragma once
// Precision and recall of appearance-based loop-closure detection over an image sequence with
// a loop ground-truth matrix (as RTAB-Map's samples_GT.bmp), and the small detector it
// evaluates: every image is a place; before it is inserted it queries the places inserted
// before it, except the most recent ones.
//
// Definitions (docs/place-recognition.md states them for readers):
//   * Image i may close a loop with image j only if j <= i - 1 - exclude_recent (a detector
//     never looks for loops among the frames it has just seen).
//   * A query *has a loop* when the ground truth marks at least one such j.
//   * At a threshold, a query *detects* when its decision (the best candidate, or the best
//     candidate that passes the geometric check) has score >= threshold. A detection is a true
//     positive when the ground truth marks (i, j), else a false positive.
//   * precision = TP / (TP + FP)  (1 when nothing is detected);
//     recall    = TP / (number of queries that have a loop).
//   A query with a loop whose detection is wrong counts as a false positive and as a miss.

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "core/bow/vocabulary.h"
#include "core/common/expected.h"
#include "tools/place-eval/epipolar_check.h"
#include "tools/vocab-train/image_features.h"

namespace evermap::bow {

// loop(i, j): images i and j (0-based, in sequence order) show the same place.
class LoopGroundTruth {
 public:
  LoopGroundTruth() = default;
  // Row-major n x n cells, nonzero = loop. Contract: cells.size() == n * n.
  LoopGroundTruth(size_t n, std::vector<uint8_t> cells);
  // A square 8-bit image, nonzero = loop; row = query image, column = matched image, both
  // counted from the top-left (cv::imread already undoes BMP's bottom-up storage). RTAB-Map's
  // samples_GT.bmp marks only past images (below the diagonal). Errors name the file.
  static Expected<LoopGroundTruth> fromImage(const std::filesystem::path& file);

  size_t size() const { return n_; }
  bool loop(size_t i, size_t j) const { return cells_[i * n_ + j] != 0; }
  size_t numCells() const;  // positive cells
  // Queries i with a loop to some j <= i - 1 - exclude_recent.
  size_t numQueriesWithLoop(int exclude_recent) const;

 private:
  size_t n_ = 0;
  std::vector<uint8_t> cells_;
};

struct SequenceOptions {
  OrbOptions orb;
  // Depth of the direct index used to guide the matches of the geometric check.
  int direct_index_depth = 2;
  // The most recent images not searched for loops.
  int exclude_recent = 10;
  // Candidates per query (best scores first) given to the geometric check.
  int candidates = 5;
  EpipolarCheckOptions geometry;

  std::string validate() const;  // empty when valid
};

struct CandidateRecord {
  size_t image = 0;  // index of the candidate image
  double score = 0;  // normalised L1 score
  int matches = 0;   // guided matches
  int inliers = 0;   // epipolar RANSAC inliers
  bool geometric_ok = false;
};

struct QueryRecord {
  size_t image = 0;
  size_t num_features = 0;
  std::vector<CandidateRecord> candidates;  // best score first
};

// Runs the detector over `images` (in order). Errors name an unreadable image.
Expected<std::vector<QueryRecord>> runLoopDetector(const std::vector<std::filesystem::path>& images,
                                                   const Vocabulary& vocabulary,
                                                   const SequenceOptions& options);

enum class Decision {
  kRawScore,        // the best-scoring candidate
  kGeometricCheck,  // the best-scoring candidate that passes the epipolar check
};

struct PrPoint {
  double threshold = 0;
  int true_positives = 0;
  int false_positives = 0;
  double precision = 1;
  double recall = 0;
};

struct PrCurve {
  Decision decision = Decision::kRawScore;
  size_t queries_with_loop = 0;
  std::vector<PrPoint> points;  // one per distinct decision score, increasing threshold
  // The operating point with the highest recall at precision 1 (threshold = the lowest such).
  PrPoint best_at_full_precision;
};

// The operating points evermap-place-eval reports by default (docs/place-recognition.md):
// with the epipolar check no score threshold is needed (the check alone decides among the top
// candidates); the raw-score threshold was picked on RTAB-Map's samples for the default
// vocabulary and does not carry over to other vocabularies (raw scores depend on the
// vocabulary's size).
inline constexpr double kDefaultGeometricThreshold = 0.0;
inline constexpr double kDefaultRawThreshold = 0.10;

// `records` must cover images 0..gt.size()-1 in order (runLoopDetector's output).
PrCurve precisionRecall(const std::vector<QueryRecord>& records, const LoopGroundTruth& gt,
                        Decision decision, int exclude_recent);
// The single point at `threshold`. With kGeometricCheck, `min_inliers` >= 0 re-decides which
// candidates pass (inliers >= min_inliers) instead of the check's recorded verdict, so the
// inlier threshold can be swept without running the detector again.
PrPoint evaluateAt(const std::vector<QueryRecord>& records, const LoopGroundTruth& gt,
                   Decision decision, int exclude_recent, double threshold, int min_inliers = -1);

}  // namespace evermap::bow
