#pragma once
// 6-DOF motion between two stereo frames from matched features with 3-D points, as FOVIS
// estimates it (Huang et al. 2011, section 3.6):
//  1. a closed-form start from the 3-D points alone (absolute orientation: Umeyama 1991 /
//     Horn 1987, core/geometry/umeyama.h), unless the caller's guess is kept;
//  2. Gauss-Newton (Levenberg-Marquardt damped) on the *bidirectional* reprojection error:
//     every match contributes the reprojection of its frame-b point into image a and of its
//     frame-a point into image b,
//       E(T) = Σ ||π_a(T p_b) - x_a||² + ||π_b(T⁻¹ p_a) - x_b||²,   T = a_T_b,
//     with right perturbations T exp(δ), δ = (υ, ω);
//  3. matches whose error in either image exceeds inlier_max_reprojection_px are dropped and
//     step 2 is repeated (a first solve pulled off by gross outliers: the bound starts at a
//     robust multiple of the median error and shrinks over a few solves); the result is
//     refused when too few remain or their mean error is too large.
// Covariance: Σ = 2 σ² H⁻¹ with H = JᵀJ of the final problem (pixels, right tangent (υ, ω)
// at a_T_b), σ the larger of the residual RMS and pixel_sigma_px; the factor 2 undoes the
// double counting of the two directions, which reuse the same measurements.

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/camera/stereo_camera.h"
#include "core/common/expected.h"
#include "core/geometry/se3.h"

namespace evermap {
class OptionList;  // core/common/option_fields.h
}  // namespace evermap

namespace evermap::core {

// One match: the observation (level-0 pixels of the rectified left image) and the 3-D point
// (left camera frame, metres) of the same feature in each frame.
struct Correspondence {
  Eigen::Vector2d uv_a;
  Eigen::Vector3d p_a;
  Eigen::Vector2d uv_b;
  Eigen::Vector3d p_b;
};

struct MotionOptions {
  int max_iterations = 15;
  // After the first solve, matches with a larger error (pixels, either image) are outliers.
  double inlier_max_reprojection_px = 2.0;
  // Graduated rejection: the outlier bound starts at 3 robust sigmas of the first solve's
  // errors (4.45 x their median) when that is above inlier_max_reprojection_px, at least
  // halves per solve and is inlier_max_reprojection_px after at most this many solves; a
  // first solve pulled off by gross outliers then sheds them instead of failing.
  // 0: FOVIS's single rejection.
  int max_rejection_rounds = 0;
  // The final mean error (pixels, both directions) may not exceed this.
  double max_mean_reprojection_px = 1.5;
  // Fewest inliers a motion is estimated from.
  int min_inliers = 10;
  // Lower bound of the pixel noise used for the covariance (pixels); also the pixel noise
  // the depth noise is weighed against.
  double pixel_sigma_px = 0.3;
  // Disparity noise (pixels) of the stereo points: each residual is whitened for the depth
  // noise of the point it reprojects, which moves the reprojection along the epipolar
  // direction (far points under translation); errors and the outlier bound are then in
  // whitened pixels. 0: the points are taken as exact (FOVIS).
  double disparity_sigma_px = 0.0;
  // Use the caller's initial motion instead of the closed-form start (it is also the
  // fallback when the points are degenerate for the closed form).
  bool use_initial_guess = false;

  Status validate() const;
  void declareOptions(OptionList& o);
};

enum class MotionStatus {
  kOk,
  kInsufficientInliers,  // fewer than min_inliers before or after the outlier rejection
  kOptimizationFailure,  // no finite, non-singular solution
  kReprojectionError,    // converged, but the mean error exceeds max_mean_reprojection_px
};
const char* toString(MotionStatus status);

struct MotionEstimate {
  MotionStatus status = MotionStatus::kInsufficientInliers;
  std::string message;  // why, when status != kOk
  SE3d a_T_b;
  Mat6 covariance = Mat6::Zero();  // right tangent (υ, ω) at a_T_b
  std::vector<int> inliers;        // indices into the correspondences, ascending
  double mean_reprojection_px = 0.0;
  int iterations = 0;

  bool ok() const { return status == MotionStatus::kOk; }
};

// Estimates a_T_b from the correspondences listed in `candidates` (e.g. a clique).
// `initial` is used when options.use_initial_guess or when the closed form fails.
MotionEstimate estimateMotion(const StereoCamera& camera_a, const StereoCamera& camera_b,
                              const std::vector<Correspondence>& matches,
                              const std::vector<int>& candidates, const SE3d& initial,
                              const MotionOptions& options);

// Reprojection errors (pixels) of one correspondence under a_T_b: into image a and into
// image b; +inf where a point falls behind a camera.
Eigen::Vector2d reprojectionErrors(const StereoCamera& camera_a, const StereoCamera& camera_b,
                                   const Correspondence& m, const SE3d& a_T_b);

// Residuals r = (π_a(T p_b) - x_a, π_b(T⁻¹ p_a) - x_b) and their Jacobian with respect to a
// right perturbation of T = a_T_b; false when a point falls behind a camera. Exposed for the
// numerical-derivative test.
bool bidirectionalResidual(const StereoCamera& camera_a, const StereoCamera& camera_b,
                           const Correspondence& m, const SE3d& a_T_b,
                           Eigen::Matrix<double, 4, 1>* r, Eigen::Matrix<double, 4, 6>* J);

}  // namespace evermap::core
