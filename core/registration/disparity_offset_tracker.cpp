#include "core/registration/disparity_offset_tracker.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

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
  if (row_slopes % 2 == 0) {
    return makeError("disparity offset tracker: row_slopes ", row_slopes,
                     " is even (the camera's own slope is the middle one)");
  }
  if (evidence.max_pairs < evidence.min_groups) {
    return makeError("disparity offset tracker: max_pairs ", evidence.max_pairs,
                     " is below min_pairs ", evidence.min_groups);
  }
  return estimate.validate();
}

Expected<DisparityOffsetTracker> DisparityOffsetTracker::create(
    const StereoCamera& camera, const DisparityOffsetTrackerOptions& options) {
  if (Status s = options.validate(); !s) return s.error();
  return DisparityOffsetTracker(camera, options);
}

DisparityOffsetTracker::DisparityOffsetTracker(const StereoCamera& camera,
                                               const DisparityOffsetTrackerOptions& options)
    : camera_(camera),
      options_(options),
      evidence_(options.estimate.grid(), rowSlopes(options), options.evidence) {}

std::vector<double> DisparityOffsetTracker::rowSlopes(const DisparityOffsetTrackerOptions& o) {
  if (o.row_slopes <= 1) return {};
  std::vector<double> rows;
  for (int i = 0; i < o.row_slopes; ++i) rows.push_back((i - o.row_slopes / 2) * o.row_slope_step);
  return rows;
}

void DisparityOffsetTracker::restart(const StereoCamera& camera) {
  camera_ = camera;
  evidence_.clear();
  state_ = DisparityOffsetState{};
}

const DisparityOffsetState& DisparityOffsetTracker::add(const StereoMatchPair& pair,
                                                        int64_t group) {
  if (!wantsPairs() || pair.uvd_a.empty() || pair.uvd_a.size() != pair.uvd_b.size()) return state_;
  const StereoMatchPair sub = subsampledPair(pair, options_.max_points_per_pair);
  if (evidence_.rows().empty()) {
    evidence_.add(pairCostCurve(camera_, sub, evidence_.grid(), options_.estimate), group);
  } else {
    // The rows on half the points (every row on the same ones: their costs are compared), only
    // for a pair its own curve makes evidence (a hovering camera's pairs cost nothing more);
    // the curve on all the points, as without rows (the pair's judgement and the offset's
    // estimate stay what they were).
    evidence_.add(
        pairCostCurve(camera_, sub, evidence_.grid(), options_.estimate),
        [&] {
          const StereoMatchPair half =
              subsampledPair(sub, std::max(1, options_.max_points_per_pair / 2));
          std::vector<std::vector<double>> table;
          for (double slope : evidence_.rows()) {
            table.push_back(pairCostCurve(camera_, withRowSlope(half, camera_.cy(), slope),
                                          evidence_.grid(), options_.estimate));
          }
          return table;
        },
        group);
  }
  state_.estimate = evidence_.estimate();
  if (!state_.estimate.message.empty()) state_.message = state_.estimate.message;
  decide();
  return state_;
}

void DisparityOffsetTracker::decide() {
  DisparityOffsetState& s = state_;
  const CurveEstimate& e = s.estimate;
  // The slope first: when it is significant, the offset is the one at that slope, and it is
  // that offset's standard error that says whether the round has converged (the offset alone
  // does not fit pairs whose points lie at different rows: its jackknife stays wide).
  const double half_height = camera_.height() / 2.0;
  const bool slope = e.groups_used >= options_.evidence.min_groups &&
                     std::isfinite(e.row_standard_error) &&
                     std::abs(e.row_value) * half_height >= options_.min_offset_px &&
                     std::abs(e.row_value) >= options_.significance * e.row_standard_error;
  const bool converged = evidence_.converged(options_.max_standard_error_px) ||
                         (slope && e.joint_standard_error <= options_.max_standard_error_px);
  if (!converged) return;
  s.offset_px = slope ? e.joint_value : e.value;
  s.row_slope = slope ? e.row_value : 0.0;
  const double total = camera_.disparityOffsetPx() + s.offset_px;
  const double size = std::abs(s.offset_px);
  const bool significant =
      slope || (size >= options_.min_offset_px && size >= options_.significance * e.standard_error);
  s.decision = significant && std::abs(total) <= options_.max_total_offset_px
                   ? OffsetDecision::kApply
                   : OffsetDecision::kKeep;
  char line[320];
  int n =
      std::snprintf(line, sizeof(line),
                    "disparity offset %+.3f px +- %.3f (jackknife) on %+.3f from %d pairs of %d "
                    "frames (%d examined, %d left out)",
                    e.value, e.standard_error, camera_.disparityOffsetPx(), e.pairs_used,
                    e.groups_used, e.pairs_examined, e.pairs_left_out);
  if (!evidence_.rows().empty() && n > 0 && static_cast<size_t>(n) < sizeof(line)) {
    n += std::snprintf(line + n, sizeof(line) - static_cast<size_t>(n),
                       "; row slope %+.5f +- %.5f px per row on %+.5f, offset %+.3f +- %.3f at it",
                       e.row_value, e.row_standard_error, camera_.disparityRowSlope(),
                       e.joint_value, e.joint_standard_error);
  }
  if (n > 0 && static_cast<size_t>(n) < sizeof(line)) {
    std::snprintf(line + n, sizeof(line) - static_cast<size_t>(n), ": %s%s%s", toString(s.decision),
                  slope && s.decision == OffsetDecision::kApply ? " with the slope" : "",
                  s.decision == OffsetDecision::kApply ? "" : " (the calibration stays)");
  }
  s.message = line;
  if (s.decision == OffsetDecision::kKeep && std::abs(total) > options_.max_total_offset_px) {
    s.message += ": beyond max_total_offset_px";
  }
}

}  // namespace evermap::core
