#pragma once
// Trajectory error metrics of Sturm et al., "A benchmark for the evaluation of RGB-D SLAM
// systems", IROS 2012, section VI:
//  - ATE, absolute trajectory error: after alignment, the distance between each estimated
//    position and its ground-truth position (their eq. 1-2), and here also the angle
//    between the orientations.
//  - RPE, relative pose error over a step Δ: E_i = (Q_i⁻¹ Q_{i+Δ})⁻¹ (P_i⁻¹ P_{i+Δ}) (eq. 3),
//    reported as the norm of its translation and the angle of its rotation. Δ is either a
//    number of matched poses or a travelled distance along the ground truth, as KITTI does.
// Inputs are matched pose lists (see association.h) with the estimate already moved into
// the ground-truth frame (alignment.h).

#include <string>
#include <vector>

#include "core/common/expected.h"
#include "core/geometry/se3.h"

namespace evermap::eval {

// Statistics of a list of non-negative errors. std is the population standard deviation
// (1/n), as numpy.std in the TUM scripts; the median of an even count averages the middle two.
struct ErrorStats {
  size_t count = 0;
  double rmse = 0.0;
  double mean = 0.0;
  double median = 0.0;
  double std = 0.0;
  double min = 0.0;
  double max = 0.0;
};

// Contract: `errors` is non-empty and finite.
ErrorStats computeStats(std::vector<double> errors);

struct AteSummary {
  ErrorStats translation_m;
  ErrorStats rotation_deg;
  std::vector<double> translation_errors_m;  // per matched pose, in order
};

// ATE of `est` (already aligned) against `gt`, paired by index. Errors: sizes differ, empty,
// non-finite.
Expected<AteSummary> computeAte(const std::vector<core::SE3d>& gt,
                                const std::vector<core::SE3d>& est);

struct RpeOptions {
  // Exactly one of the two is positive.
  int delta_frames = 1;           // Δ in matched poses
  double delta_distance_m = 0.0;  // Δ as distance travelled along the ground truth, metres

  Status validate() const;
  bool byDistance() const { return delta_distance_m > 0.0; }
};

struct RpeSummary {
  RpeOptions options;
  ErrorStats translation_m;
  ErrorStats rotation_deg;
};

// RPE over all pairs (i, j) with j = i + Δ frames, or j the first pose at least Δ metres
// further along the ground truth. Errors: bad options, sizes differ, no pair (the trajectory
// is shorter than Δ).
Expected<RpeSummary> computeRpe(const std::vector<core::SE3d>& gt,
                                const std::vector<core::SE3d>& est, const RpeOptions& options);

// Cumulative distance travelled along `poses`: out[0] = 0, out[k] = out[k-1] + |t_k - t_k-1|.
std::vector<double> cumulativeDistances(const std::vector<core::SE3d>& poses);

}  // namespace evermap::eval
