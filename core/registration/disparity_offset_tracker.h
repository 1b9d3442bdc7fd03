#pragma once
// A stereo rig's disparity offset (disparity_offset.h: true disparity = measured + offset,
// cx_right - cx_left of the images against the calibration) estimated online, from the pairs of
// frames a visual odometry registers anyway, in rounds: each round gathers evidence until it
// can decide, the offset is applied when the decision says so, and the next round measures
// what is left over, until one finds nothing to change.
//
// Each pair added gives its own cost curve over a grid of candidate offsets (pairCostCurve), and
// the evidence is judged as curve_evidence.h says (flat curves and outliers not used, a
// jackknife over reference frames for the standard error). It has converged when pairs of at
// least min_pairs groups (evidence.min_groups) are used and the standard error is at most
// max_standard_error_px. Then it is applied (kApply) only when it is at least min_offset_px and
// significance standard errors from 0, and the camera's offset stays within max_total_offset_px;
// otherwise the calibration is kept (kKeep): a well-calibrated rig stays at 0. The grid (around the
// camera's offset) bounds one round's step. The caller starts the next round (restart) after
// kApply; after kKeep the tracker stays decided (StereoOdometry stops there: every further round
// would be another chance of a false alarm on a right rig). "Measured" is what the pairs carry:
// with a camera that already has an offset, the estimate is what is left over.
//
// The disparity's row slope (stereo_camera.h: d = d_measured + offset + slope (v - cy)) is
// estimated with it, on row_slopes candidates row_slope_step apart around the camera's: each
// pair's curve is computed under each, on half its points (curve_evidence.h, "rows"). When the
// slope is significant (its effect half an image above or below cy at least min_offset_px, and
// `significance` standard errors from 0), the slope and the offset at it are applied together;
// otherwise the decision is the offset's alone, as without the slope. Both are needed where the
// disparity error grows towards the image's bottom (the KITTI clip: +1.29 px at cy and +0.004
// px per row from the images, against +0.80 px for an offset alone).

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "core/camera/stereo_camera.h"
#include "core/common/expected.h"
#include "core/common/option_fields.h"
#include "core/registration/curve_evidence.h"
#include "core/registration/disparity_offset.h"

namespace evermap::core {

struct DisparityOffsetTrackerOptions {
  DisparityOffsetOptions estimate = defaultEstimate();
  // A pair's inliers beyond this many are subsampled evenly (the cost of a curve).
  int max_points_per_pair = 100;
  // How the pairs' curves are judged (curve_evidence.h; in pixels): max_pair_sigma 1 px,
  // min_groups 8 reference frames, max_pairs 150, outliers beyond 3 MADs and 0.5 px.
  CurveEvidenceOptions evidence;
  double max_standard_error_px = 0.08;
  double min_offset_px = 0.15;
  // The camera's offset is never moved beyond this (pixels, either sign).
  double max_total_offset_px = 3.0;
  double significance = 4.0;  // standard errors
  // Candidate row slopes per round (odd; 1: the offset alone) and their spacing (px per row).
  int row_slopes = 5;
  double row_slope_step = 0.004;

  static DisparityOffsetOptions defaultEstimate();
  Status validate() const;
  void declareOptions(OptionList& o) {
    o.add("max_points_per_pair", &max_points_per_pair, "points",
          "a registered pair's inliers beyond this are subsampled")
        .min(10);
    o.add("max_pair_sigma_px", &evidence.max_pair_sigma, "px",
          "a pair whose own curve is flatter than this is not evidence")
        .positive();
    o.add("min_pairs", &evidence.min_groups, "pairs",
          "pairs of at least this many reference frames to decide")
        .min(3);
    o.add("max_pairs", &evidence.max_pairs, "pairs",
          "a round keeps the last this many informative pairs")
        .min(1);
    o.add("max_standard_error_px", &max_standard_error_px, "px",
          "converged when the jackknife standard error is at most this")
        .positive();
    o.add("min_offset_px", &min_offset_px, "px", "a smaller converged offset is not applied")
        .nonNegative();
    o.add("significance", &significance, "sigmas",
          "... nor one within this many standard errors of 0")
        .nonNegative();
    o.add("max_total_offset_px", &max_total_offset_px, "px",
          "the camera's offset is never moved beyond this")
        .nonNegative();
    o.add("row_slopes", &row_slopes, "candidates",
          "row slopes tried per round around the camera's (odd; 1: the offset alone)")
        .min(1);
    o.add("row_slope_step", &row_slope_step, "px per row", "between candidate row slopes")
        .positive();
    o.add("outlier_mads", &evidence.outlier_mads, "MADs",
          "a pair's own minimum this far from the median's is left out ...")
        .positive();
    o.add("min_outlier_distance_px", &evidence.min_outlier_distance, "px",
          "... and at least this far")
        .nonNegative();
    o.add("grid_min_px", &estimate.min_offset_px, "px", "smallest offset considered").any();
    o.add("grid_max_px", &estimate.max_offset_px, "px", "largest offset considered").any();
    o.add("grid_step_px", &estimate.step_px, "px", "between candidate offsets").positive();
  }
};

enum class OffsetDecision { kPending, kApply, kKeep };
const char* toString(OffsetDecision decision);

struct DisparityOffsetState {
  OffsetDecision decision = OffsetDecision::kPending;
  CurveEstimate estimate;  // the offset in pixels (0 until pairs of min_groups frames are used)
  // kApply: what to add to the camera's offset (px) and row slope (px per row).
  double offset_px = 0.0;
  double row_slope = 0.0;
  std::string message;  // one line
};

class DisparityOffsetTracker {
 public:
  // Refuses invalid options. `camera` measured the pairs.
  static Expected<DisparityOffsetTracker> create(const StereoCamera& camera,
                                                 const DisparityOffsetTrackerOptions& options);

  // Whether another pair is wanted: no decision yet in this round.
  bool wantsPairs() const { return state_.decision == OffsetDecision::kPending; }
  // A new round with `camera` (after a decision; with the offset applied): pairs measured with
  // it, the evidence so far dropped.
  void restart(const StereoCamera& camera);
  // One registered pair (matchPair, or the odometry's matches) of `group` (pairs that share a
  // frame: the same group); the decision is updated.
  const DisparityOffsetState& add(const StereoMatchPair& pair, int64_t group);
  const DisparityOffsetState& state() const { return state_; }

 private:
  DisparityOffsetTracker(const StereoCamera& camera, const DisparityOffsetTrackerOptions& options);
  static std::vector<double> rowSlopes(const DisparityOffsetTrackerOptions& options);
  void decide();

  StereoCamera camera_;
  DisparityOffsetTrackerOptions options_;
  CurveEvidence evidence_;
  DisparityOffsetState state_;
};

}  // namespace evermap::core
