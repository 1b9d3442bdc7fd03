#pragma once
// KITTI odometry drift, as the devkit of Geiger et al. ("Are we ready for autonomous
// driving? The KITTI vision benchmark suite", CVPR 2012; evaluate_odometry.cpp) computes it:
// from every 10th matched pose, for each segment length L in {100, ..., 800} m, take the
// first pose whose distance along the ground truth exceeds L, and compare the relative
// motions:  E = (P_first⁻¹ P_last)⁻¹ (Q_first⁻¹ Q_last)  (P estimate, Q ground truth).
// Translation error = |t(E)| / L, rotation error = angle(E) / L, averaged over all segments
// of all lengths; reported as percent and as degrees per 100 m, the figures of the KITTI
// leaderboard.

#include <vector>

#include "core/common/expected.h"
#include "core/geometry/se3.h"

namespace evermap::eval {

struct KittiDriftOptions {
  std::vector<double> segment_lengths_m = {100, 200, 300, 400, 500, 600, 700, 800};
  size_t step_frames = 10;  // start a segment at every step_frames-th matched pose

  Status validate() const;
};

struct KittiDriftLength {
  double length_m = 0.0;
  size_t segments = 0;  // 0 when the path is shorter than length_m
  double translation_percent = 0.0;
  double rotation_deg_per_100m = 0.0;
};

struct KittiDriftSummary {
  size_t segments = 0;
  double translation_percent = 0.0;    // mean of |t(E)| / L, in %
  double rotation_deg_per_100m = 0.0;  // mean of angle(E) / L, in deg per 100 m
  std::vector<KittiDriftLength> per_length;
};

// `gt` and `est` are matched poses (same length, in time order). An error when the ground
// truth is shorter than the shortest segment (no segment fits), or on bad input.
Expected<KittiDriftSummary> computeKittiDrift(const std::vector<core::SE3d>& gt,
                                              const std::vector<core::SE3d>& est,
                                              const KittiDriftOptions& options = {});

}  // namespace evermap::eval
