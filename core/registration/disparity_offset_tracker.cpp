#include "core/registration/disparity_offset_tracker.h"

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
    : camera_(camera), options_(options), evidence_(options.estimate.grid(), options.evidence) {}

void DisparityOffsetTracker::restart(const StereoCamera& camera) {
  camera_ = camera;
  evidence_.clear();
  state_ = DisparityOffsetState{};
}

const DisparityOffsetState& DisparityOffsetTracker::add(const StereoMatchPair& pair,
                                                        int64_t group) {
  if (!wantsPairs() || pair.uvd_a.empty() || pair.uvd_a.size() != pair.uvd_b.size()) return state_;
  evidence_.add(pairCostCurve(camera_, subsampledPair(pair, options_.max_points_per_pair),
                              evidence_.grid(), options_.estimate),
                group);
  state_.estimate = evidence_.estimate();
  if (!state_.estimate.message.empty()) state_.message = state_.estimate.message;
  decide();
  return state_;
}

void DisparityOffsetTracker::decide() {
  DisparityOffsetState& s = state_;
  if (!evidence_.converged(options_.max_standard_error_px)) return;
  const CurveEstimate& e = s.estimate;
  const double total = camera_.disparityOffsetPx() + e.value;
  const double size = std::abs(e.value);
  const bool significant =
      size >= options_.min_offset_px && size >= options_.significance * e.standard_error;
  s.decision = significant && std::abs(total) <= options_.max_total_offset_px
                   ? OffsetDecision::kApply
                   : OffsetDecision::kKeep;
  char line[200];
  std::snprintf(line, sizeof(line),
                "disparity offset %+.3f px +- %.3f (jackknife) on %+.3f from %d pairs of %d frames "
                "(%d examined, %d left out): %s%s",
                e.value, e.standard_error, camera_.disparityOffsetPx(), e.pairs_used, e.groups_used,
                e.pairs_examined, e.pairs_left_out, toString(s.decision),
                s.decision == OffsetDecision::kApply ? "" : " (the calibration stays)");
  s.message = line;
  if (s.decision == OffsetDecision::kKeep && std::abs(total) > options_.max_total_offset_px) {
    s.message += ": beyond max_total_offset_px";
  }
}

}  // namespace evermap::core
