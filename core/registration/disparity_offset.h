#pragma once
// The disparity offset of a rectified stereo rig, estimated from its own images: the constant
// delta such that true disparity = measured + delta, i.e. d = fx b / z + (cx_left - cx_right)
// with delta = cx_right - cx_left of the images against a calibration that says they are equal
// (Middlebury's "doffs"; a crop or principal point of the right image that differs from the
// calibration's).
//
// Why it is observable without ground truth: a wrong offset maps each frame's stereo points
// through a projective transformation (z' = fx b / (fx b / z - delta): far points move most),
// and no rigid motion maps one distorted frame onto the next unless the scene's depths are all
// alike; a wrong baseline only scales the points and is not observable this way.
//
// Method: for each candidate offset on a grid, the motion of every registered pair of frames is
// re-estimated (Gauss-Newton from the registration's, both directions: b's points projected
// into a and a's into b, residuals in u, v and d, Huber); the offset of least total cost wins,
// refined by a parabola through its neighbours. The pairs' inliers are chosen by the caller
// (e.g. registerFrames at offset 0), which biases the estimate towards 0 if at all.
// "Measured" is what the features carry: with a camera that has a disparity offset of its own
// (StereoCamera::disparityOffsetPx, applied by StereoDepth), the estimate is what is left over.
//
// Online (vo-proc, DisparityOffsetTracker below): each registered pair gives its own estimate
// and standard deviation (pairOffsetEvidence: Gauss-Newton over the motion and the offset
// together, the offset's variance from the Schur complement of the robust normal equations,
// scaled by the residuals' own variance); the pairs are combined by inverse variance, the
// combined sigma inflated by the pairs' scatter when they disagree more than their sigmas say.

#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "core/camera/stereo_camera.h"
#include "core/common/expected.h"
#include "core/geometry/se3.h"
#include "core/registration/frame_registration.h"
#include "core/registration/keyframe_features.h"

namespace evermap::core {

// The inliers of two registered stereo frames: measured (u, v, d) in level-0 pixels, in a and
// in b (same index = same point), and the registration's a_T_b as the start of each solve.
struct StereoMatchPair {
  std::vector<Eigen::Vector3d> uvd_a, uvd_b;
  SE3d a_T_b;
};

// The inliers of registerFrames(camera, a, camera, b) as a pair (empty unless it succeeded).
StereoMatchPair matchPair(const KeyframeFeatures& a, const KeyframeFeatures& b,
                          const RegistrationSummary& registration);

struct DisparityOffsetOptions {
  // The grid of candidate offsets (pixels). A candidate under which some disparity would be
  // <= 0 is skipped.
  double min_offset_px = -2.0;
  double max_offset_px = 3.0;
  double step_px = 0.1;
  // Measurement noise the residuals are divided by (pixels), and the Huber threshold (sigmas).
  double sigma_uv_px = 0.5;
  double sigma_d_px = 0.3;
  double huber_sigmas = 2.0;
  int gauss_newton_iterations = 8;

  Status validate() const;
};

struct DisparityOffsetSummary {
  double offset_px = 0.0;  // true disparity = measured + offset_px
  int pairs = 0;
  int matches = 0;
  std::vector<std::pair<double, double>> curve;  // (offset px, total robust cost)
  std::string message;
};

// Errors: invalid options, no pair with matches, no candidate offset that every disparity
// allows, or a minimum at an end of the grid (widen it).
Expected<DisparityOffsetSummary> estimateDisparityOffset(const StereoCamera& camera,
                                                         const std::vector<StereoMatchPair>& pairs,
                                                         const DisparityOffsetOptions& options);

// One pair's evidence: the offset that fits it best and its standard deviation (pixels).
struct OffsetEvidence {
  double offset_px = 0.0;
  double sigma_px = 0.0;
  int matches = 0;
};

// Gauss-Newton over the pair's motion and the offset jointly, from the registration's motion
// and offset 0 (options: the sigmas, Huber threshold and iterations; the grid is not used).
// The variance is the offset's entry of the inverse robust normal matrix times the residuals'
// variance factor, doubled: every measurement enters twice (both directions). Errors: fewer
// than 7 matches, or the offset not determined (a pair without translation: the cost is flat).
Expected<OffsetEvidence> pairOffsetEvidence(const StereoCamera& camera, const StereoMatchPair& pair,
                                            const DisparityOffsetOptions& options);

// The offset of a rig estimated while it runs: evidence added pair by pair until the combined
// sigma is at most converged_sigma_px (after at least min_pairs); then it stops and says
// whether the offset is to be applied: |offset| >= significance_sigmas sigma (within that, the
// rig is as calibrated and stays so).
class DisparityOffsetTracker {
 public:
  struct Options {
    DisparityOffsetOptions estimate;  // sigmas, Huber threshold, iterations
    int min_matches = 30;             // a pair with fewer is not used
    int min_pairs = 5;                // the scatter needs a few pairs to mean something
    double converged_sigma_px = 0.1;
    double significance_sigmas = 3.0;
    // A pair whose estimate is farther than this from 0 is a failed solve, not evidence.
    double max_abs_offset_px = 5.0;

    Status validate() const;
  };

  explicit DisparityOffsetTracker(const Options& options) : options_(options) {}

  // Adds a pair (nothing once converged); false when it was not used (too few matches, no
  // translation, failed solve).
  bool add(const StereoCamera& camera, const StereoMatchPair& pair);

  bool converged() const { return converged_; }
  // Converged and significant: the offset to apply.
  bool significant() const;
  double offsetPx() const { return offset_px_; }
  double sigmaPx() const { return sigma_px_; }
  int pairs() const { return static_cast<int>(evidence_.size()); }
  const std::vector<OffsetEvidence>& evidence() const { return evidence_; }
  // "disparity offset +0.78 px +- 0.09 (12 pairs, 2400 matches): applied" and the like.
  std::string describe() const;

 private:
  void combine();

  Options options_;
  std::vector<OffsetEvidence> evidence_;
  double offset_px_ = 0.0;
  double sigma_px_ = 0.0;
  bool converged_ = false;
};

}  // namespace evermap::core
