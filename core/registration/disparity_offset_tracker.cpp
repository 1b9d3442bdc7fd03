#include "core/registration/disparity_offset_tracker.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <utility>

namespace evermap::core {

const char* toString(OffsetDecision decision) {
  switch (decision) {
    case OffsetDecision::kPending:
      return "pending";
    case OffsetDecision::kApply:
      return "applied";
    case OffsetDecision::kKeep:
      return "kept the calibration";
  }
  return "?";
}

DisparityOffsetOptions DisparityOffsetTrackerOptions::defaultEstimate() {
  DisparityOffsetOptions o;
  // Online: a coarser grid (the parabola refines the minimum) around the camera's offset, and
  // fewer iterations (each solve starts from its neighbour's motion).
  o.min_offset_px = -2.0;
  o.max_offset_px = 2.0;
  o.step_px = 0.25;
  o.gauss_newton_iterations = 3;
  return o;
}

Status DisparityOffsetTrackerOptions::validate() const {
  if (Status s = checkOptionRanges(*this); !s) return s;
  if (max_pairs < min_pairs) {
    return makeError("disparity offset tracker: max_pairs ", max_pairs, " is below min_pairs ",
                     min_pairs);
  }
  return estimate.validate();
}

Expected<DisparityOffsetTracker> DisparityOffsetTracker::create(
    const StereoCamera& camera, const DisparityOffsetTrackerOptions& options) {
  if (Status s = options.validate(); !s) return s.error();
  return DisparityOffsetTracker(camera, options);
}

namespace {

double median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + long(v.size() / 2), v.end());
  return v[v.size() / 2];
}

// At most `max_points` of the pair's points, evenly spaced.
StereoMatchPair subsampled(const StereoMatchPair& pair, int max_points) {
  const size_t n = pair.uvd_a.size();
  if (n <= static_cast<size_t>(max_points)) return pair;
  StereoMatchPair out;
  out.a_T_b = pair.a_T_b;
  for (int i = 0; i < max_points; ++i) {
    const size_t k = static_cast<size_t>(i) * n / static_cast<size_t>(max_points);
    out.uvd_a.push_back(pair.uvd_a[k]);
    out.uvd_b.push_back(pair.uvd_b[k]);
  }
  return out;
}

}  // namespace

void DisparityOffsetTracker::restart(const StereoCamera& camera) {
  camera_ = camera;
  curves_.clear();
  minima_.clear();
  groups_.clear();
  state_ = DisparityOffsetState{};
}

const DisparityOffsetState& DisparityOffsetTracker::add(const StereoMatchPair& pair,
                                                        int64_t group) {
  if (!wantsPairs() || pair.uvd_a.empty() || pair.uvd_a.size() != pair.uvd_b.size()) return state_;
  ++state_.pairs_examined;
  std::vector<double> costs = pairCostCurve(camera_, subsampled(pair, options_.max_points_per_pair),
                                            offsets_, options_.estimate);
  const Expected<double> own = leastCostOffset(offsets_, costs);
  if (own) {
    // Its curvature at the minimum: the information of this pair alone.
    const double least = *std::min_element(costs.begin(), costs.end());
    const size_t best =
        static_cast<size_t>(std::min_element(costs.begin(), costs.end()) - costs.begin());
    const double step = options_.estimate.step_px;
    const double curvature =
        (costs[best - 1] - 2.0 * costs[best] + costs[best + 1]) / (step * step);
    if (curvature > 0.0 && 1.0 / std::sqrt(curvature) <= options_.max_pair_sigma_px) {
      for (double& c : costs) c -= least;
      curves_.push_back(std::move(costs));
      minima_.push_back(*own);
      groups_.push_back(group);
      if (curves_.size() > static_cast<size_t>(options_.max_pairs)) {
        curves_.erase(curves_.begin());
        minima_.erase(minima_.begin());
        groups_.erase(groups_.begin());
      }
    }
  }
  estimate();
  decide();
  return state_;
}

void DisparityOffsetTracker::estimate() {
  const size_t n = curves_.size();
  if (n < static_cast<size_t>(options_.min_pairs)) return;
  // Pairs whose own minimum is far from the others' are left out.
  const double mid = median(minima_);
  std::vector<double> deviations;
  for (double m : minima_) deviations.push_back(std::abs(m - mid));
  const double bound = std::max(options_.outlier_mads * 1.4826 * median(deviations),
                                options_.min_outlier_distance_px);
  std::vector<size_t> used;
  for (size_t i = 0; i < n; ++i) {
    if (std::abs(minima_[i] - mid) <= bound) used.push_back(i);
  }
  state_.pairs_used = static_cast<int>(used.size());
  state_.pairs_left_out = static_cast<int>(n - used.size());
  std::vector<int64_t> groups;
  for (size_t i : used) groups.push_back(groups_[i]);
  std::sort(groups.begin(), groups.end());
  groups.erase(std::unique(groups.begin(), groups.end()), groups.end());
  state_.groups_used = static_cast<int>(groups.size());
  if (groups.size() < static_cast<size_t>(options_.min_pairs)) return;
  std::vector<double> total(offsets_.size(), 0.0);
  for (size_t i : used) {
    for (size_t s = 0; s < total.size(); ++s) total[s] += curves_[i][s];
  }
  const Expected<double> all = leastCostOffset(offsets_, total);
  if (!all) {
    state_.message = all.error().message;
    return;
  }
  // Jackknife: the estimate with each group left out in turn.
  std::vector<double> partial;
  for (int64_t g : groups) {
    std::vector<double> without = total;
    for (size_t i : used) {
      if (groups_[i] != g) continue;
      for (size_t s = 0; s < total.size(); ++s) without[s] -= curves_[i][s];
    }
    const Expected<double> e = leastCostOffset(offsets_, without);
    if (!e) return;  // one group holds the minimum inside the grid: not converged
    partial.push_back(*e);
  }
  double mean = 0.0;
  for (double p : partial) mean += p / static_cast<double>(partial.size());
  double sum = 0.0;
  for (double p : partial) sum += (p - mean) * (p - mean);
  const double m = static_cast<double>(partial.size());
  state_.offset_px = *all;
  state_.standard_error_px = std::sqrt((m - 1.0) / m * sum);
}

void DisparityOffsetTracker::decide() {
  DisparityOffsetState& s = state_;
  const bool converged =
      s.groups_used >= options_.min_pairs && s.standard_error_px <= options_.max_standard_error_px;
  if (!converged) return;
  const double total = camera_.disparityOffsetPx() + s.offset_px;
  const double size = std::abs(s.offset_px);
  const bool significant =
      size >= options_.min_offset_px && size >= options_.significance * s.standard_error_px;
  s.decision = significant && std::abs(total) <= options_.max_total_offset_px
                   ? OffsetDecision::kApply
                   : OffsetDecision::kKeep;
  char line[200];
  std::snprintf(line, sizeof(line),
                "disparity offset %+.3f px +- %.3f (jackknife) on %+.3f from %d pairs of %d frames "
                "(%d examined, %d left out): %s%s",
                s.offset_px, s.standard_error_px, camera_.disparityOffsetPx(), s.pairs_used,
                s.groups_used, s.pairs_examined, s.pairs_left_out, toString(s.decision),
                s.decision == OffsetDecision::kApply ? "" : " (the calibration stays)");
  s.message = line;
  if (s.decision == OffsetDecision::kKeep && std::abs(total) > options_.max_total_offset_px) {
    s.message += ": beyond max_total_offset_px";
  }
}

}  // namespace evermap::core
