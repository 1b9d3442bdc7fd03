#include "tools/place-eval/loop_evaluation.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>

#include <opencv2/imgcodecs.hpp>

#include "core/bow/place_database.h"

namespace evermap::bow {

LoopGroundTruth::LoopGroundTruth(size_t n, std::vector<uint8_t> cells)
    : n_(n), cells_(std::move(cells)) {
  if (cells_.size() != n_ * n_) {
    std::fprintf(stderr, "evermap: LoopGroundTruth of size %zu given %zu cells\n", n_,
                 cells_.size());
    std::abort();
  }
}

Expected<LoopGroundTruth> LoopGroundTruth::fromImage(const std::filesystem::path& file) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(file, ec))
    return makeError(file.string(), ": no such file");
  const cv::Mat m = cv::imread(file.string(), cv::IMREAD_GRAYSCALE);
  if (m.empty()) return makeError(file.string(), ": not a readable image");
  if (m.rows != m.cols) {
    return makeError(file.string(), ": a loop matrix must be square, got ", m.cols, "x", m.rows);
  }
  const auto n = static_cast<size_t>(m.rows);
  std::vector<uint8_t> cells(n * n);
  for (int r = 0; r < m.rows; ++r) {
    for (int c = 0; c < m.cols; ++c) {
      cells[static_cast<size_t>(r) * n + static_cast<size_t>(c)] = m.at<uint8_t>(r, c) ? 1 : 0;
    }
  }
  return LoopGroundTruth(n, std::move(cells));
}

size_t LoopGroundTruth::numCells() const {
  return static_cast<size_t>(std::count(cells_.begin(), cells_.end(), uint8_t{1}));
}

size_t LoopGroundTruth::numQueriesWithLoop(int exclude_recent) const {
  size_t count = 0;
  for (size_t i = 0; i < n_; ++i) {
    const int64_t last = static_cast<int64_t>(i) - 1 - exclude_recent;
    for (int64_t j = 0; j <= last; ++j) {
      if (loop(i, static_cast<size_t>(j))) {
        ++count;
        break;
      }
    }
  }
  return count;
}

std::string SequenceOptions::validate() const {
  if (Status s = orb.validate(); !s) return "orb: " + s.error().message;
  if (std::string why = geometry.validate(); !why.empty()) return "geometry: " + why;
  if (direct_index_depth < 1) return "direct_index_depth must be >= 1";
  if (exclude_recent < 0) return "exclude_recent must be >= 0";
  if (candidates < 1) return "candidates must be >= 1";
  return {};
}

Expected<std::vector<QueryRecord>> runLoopDetector(const std::vector<std::filesystem::path>& images,
                                                   const Vocabulary& vocabulary,
                                                   const SequenceOptions& options) {
  if (std::string why = options.validate(); !why.empty()) {
    return makeError("loop detector options: ", why);
  }
  std::vector<ImageFeatures> features;
  std::vector<FeatureVector> direct(images.size());
  std::vector<QueryRecord> out(images.size());
  PlaceDatabase db(vocabulary.numWords(), vocabulary.fingerprint());
  PlaceQuery q;
  q.top_k = options.candidates;
  for (size_t i = 0; i < images.size(); ++i) {
    auto f = extractOrbFromFile(images[i], options.orb);
    if (!f) return f.error();
    features.push_back(std::move(*f));
    Place place;
    place.id = static_cast<int64_t>(i);
    place.utime = static_cast<int64_t>(i);
    vocabulary.transform(features[i].descriptors, options.direct_index_depth, &place.bow,
                         &direct[i]);
    QueryRecord& record = out[i];
    record.image = i;
    record.num_features = features[i].descriptors.size();
    q.newest_id = static_cast<int64_t>(i) - 1 - options.exclude_recent;
    if (q.newest_id >= 0) {
      auto matches = db.query(place.bow, q);
      if (!matches) return matches.error();
      for (const PlaceMatch& m : *matches) {
        const auto j = static_cast<size_t>(m.id);
        const EpipolarCheckResult g =
            checkEpipolar(features[i], direct[i], features[j], direct[j], options.geometry);
        record.candidates.push_back({j, m.score, g.matches, g.inliers, g.accepted});
      }
    }
    if (Status s = db.insert(std::move(place)); !s) return s.error();
  }
  return out;
}

namespace {

// The decision of one query: the chosen candidate, or null.
const CandidateRecord* decide(const QueryRecord& r, Decision decision, int min_inliers) {
  for (const CandidateRecord& c : r.candidates) {
    if (decision == Decision::kRawScore) return &c;
    if (min_inliers >= 0 ? c.inliers >= min_inliers : c.geometric_ok) return &c;
  }
  return nullptr;
}

}  // namespace

PrPoint evaluateAt(const std::vector<QueryRecord>& records, const LoopGroundTruth& gt,
                   Decision decision, int exclude_recent, double threshold, int min_inliers) {
  PrPoint p;
  p.threshold = threshold;
  for (size_t i = 0; i < records.size() && i < gt.size(); ++i) {
    const CandidateRecord* c = decide(records[i], decision, min_inliers);
    if (!c || c->score < threshold) continue;
    if (gt.loop(i, c->image)) {
      ++p.true_positives;
    } else {
      ++p.false_positives;
    }
  }
  const int detected = p.true_positives + p.false_positives;
  p.precision = detected > 0 ? static_cast<double>(p.true_positives) / detected : 1.0;
  const size_t with_loop = gt.numQueriesWithLoop(exclude_recent);
  p.recall = with_loop > 0 ? static_cast<double>(p.true_positives) / with_loop : 0.0;
  return p;
}

PrCurve precisionRecall(const std::vector<QueryRecord>& records, const LoopGroundTruth& gt,
                        Decision decision, int exclude_recent) {
  PrCurve curve;
  curve.decision = decision;
  curve.queries_with_loop = gt.numQueriesWithLoop(exclude_recent);
  std::vector<double> thresholds;
  for (const QueryRecord& r : records) {
    if (const CandidateRecord* c = decide(r, decision, -1)) thresholds.push_back(c->score);
  }
  std::sort(thresholds.begin(), thresholds.end());
  thresholds.erase(std::unique(thresholds.begin(), thresholds.end()), thresholds.end());
  // Above every score: nothing detected (precision 1, recall 0).
  const double top = thresholds.empty() ? 1.0 : thresholds.back();
  thresholds.push_back(std::nextafter(top, std::numeric_limits<double>::infinity()));
  for (double t : thresholds) {
    curve.points.push_back(evaluateAt(records, gt, decision, exclude_recent, t));
  }
  curve.best_at_full_precision = curve.points.back();
  for (const PrPoint& p : curve.points) {
    if (p.false_positives == 0 && p.recall > curve.best_at_full_precision.recall) {
      curve.best_at_full_precision = p;
    }
  }
  return curve;
}

}  // namespace evermap::bow
