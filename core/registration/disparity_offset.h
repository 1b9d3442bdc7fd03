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
// omega_a, omega_b: each frame's angular velocity (rad/s, its camera frame), what a rolling
// shutter's line delay acts through (core/camera/rolling_shutter.h); zero when not known.
struct StereoMatchPair {
  std::vector<Eigen::Vector3d> uvd_a, uvd_b;
  SE3d a_T_b;
  Eigen::Vector3d omega_a = Eigen::Vector3d::Zero(), omega_b = Eigen::Vector3d::Zero();
};

// At most `max_points` of the pair's points, evenly spaced (the cost of a curve).
StereoMatchPair subsampledPair(const StereoMatchPair& pair, int max_points);

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
  // The candidate offsets, min_offset_px + k step_px up to max_offset_px (evenGrid).
  std::vector<double> grid() const;
};

// min + k step for k = 0, 1, ... up to max (a candidate grid of a cost curve).
std::vector<double> evenGrid(double min, double max, double step);

struct DisparityOffsetSummary {
  double offset_px = 0.0;  // true disparity = measured + offset_px
  int pairs = 0;
  int matches = 0;
  std::vector<std::pair<double, double>> curve;  // (offset px, total robust cost)
  std::string message;
};

// The robust cost of one pair at each of `offsets` (infinity where some disparity + offset <= 0),
// each at the motion that minimises it (warm-started from the neighbouring candidate's).
std::vector<double> pairCostCurve(const StereoCamera& camera, const StereoMatchPair& pair,
                                  const std::vector<double>& offsets,
                                  const DisparityOffsetOptions& options);

// The robust cost of one pair at each of `line_delays_s` (seconds per row, added to what the
// pair's measurements were corrected with; core/camera/rolling_shutter.h), each at the motion
// that minimises it, as pairCostCurve. A pair whose frames did not turn has a flat curve.
std::vector<double> pairLineDelayCurve(const StereoCamera& camera, const StereoMatchPair& pair,
                                       const std::vector<double>& line_delays_s,
                                       const DisparityOffsetOptions& options);

// The minimum of a cost curve over `offsets`, refined by a parabola through its neighbours.
// Errors: no finite cost, or the least cost at an end of the grid (or next to an infinite one).
Expected<double> leastCostOffset(const std::vector<double>& offsets,
                                 const std::vector<double>& costs);
// The same, with the parabola's least cost: (argument, cost).
Expected<std::pair<double, double>> leastCostPoint(const std::vector<double>& offsets,
                                                   const std::vector<double>& costs);

// With a second parameter on `rows` (increasing, evenly spaced, at least 2), `table` one curve
// over `grid` per row: the row where the rows' least costs are least (a parabola through them;
// a row whose least cost is at an end of the grid counts its least candidate), and the first
// parameter there (linear between the two rows around it): (row, value). Errors: the rows'
// least cost at an end of the rows.
Expected<std::pair<double, double>> leastCostProfile(const std::vector<double>& grid,
                                                     const std::vector<double>& rows,
                                                     const std::vector<std::vector<double>>& table);

// The pair with `slope` x (v - cy) added to every disparity (both frames): its measurements
// under a disparity row slope (stereo_camera.h) that much larger.
StereoMatchPair withRowSlope(const StereoMatchPair& pair, double cy, double slope);

// Errors: invalid options, no pair with matches, no candidate offset that every disparity
// allows, or a minimum at an end of the grid (widen it).
Expected<DisparityOffsetSummary> estimateDisparityOffset(const StereoCamera& camera,
                                                         const std::vector<StereoMatchPair>& pairs,
                                                         const DisparityOffsetOptions& options);

// The offset and the row slope together (stereo_camera.h: d = d_measured + offset + slope
// (v - cy)): the pairs' summed curve over the offsets under each candidate slope of `slopes`
// (increasing, evenly spaced, at least 3), and their leastCostProfile.
struct DisparityPlaneSummary {
  double offset_px = 0.0;
  double row_slope = 0.0;
};
Expected<DisparityPlaneSummary> estimateDisparityPlane(const StereoCamera& camera,
                                                       const std::vector<StereoMatchPair>& pairs,
                                                       const DisparityOffsetOptions& options,
                                                       const std::vector<double>& slopes);

}  // namespace evermap::core
