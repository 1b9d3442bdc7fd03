#pragma once
// Pairing the poses of an estimate with those of the ground truth by time stamp.
//
// Each estimated pose is paired with the ground-truth pose nearest in time, if that is at
// most `max_dt_s` away; a ground-truth pose is used at most once (when two estimates want
// the same one, the nearer keeps it). This is the matching of the TUM benchmark's
// associate.py (Sturm et al., IROS 2012) for the usual case of sorted stamps, in
// O(n log n) instead of its greedy search over all candidate pairs.

#include <cstdint>
#include <string>
#include <vector>

#include "core/common/expected.h"
#include "tools/eval/trajectory.h"

namespace evermap::eval {

struct AssociationOptions {
  // Largest stamp difference of a pair, seconds. 0.02 s is associate.py's default; KITTI
  // files without times have stamps 1 s apart, so any value below 0.5 s pairs them by line.
  double max_dt_s = 0.02;

  Status validate() const;
};

// Matched poses, in time order: gt[k] and est[k] belong together.
struct Association {
  std::vector<int64_t> t_ns;     // stamps of the ground-truth poses
  std::vector<core::SE3d> gt;    // world_T_body of the ground truth
  std::vector<core::SE3d> est;   // world'_T_body of the estimate (its own world frame)
  std::vector<size_t> gt_index;  // indices into the input trajectories
  std::vector<size_t> est_index;
  size_t gt_poses = 0;  // sizes of the inputs, for the summary
  size_t est_poses = 0;
  double max_abs_dt_s = 0.0;  // largest |t_est - t_gt| among the pairs
  double mean_abs_dt_s = 0.0;

  size_t size() const { return gt.size(); }
};

// An error when either trajectory is invalid or no pair is found; the message names both
// sources and the time spans they cover.
Expected<Association> associate(const Trajectory& gt, const Trajectory& est,
                                const AssociationOptions& options = {});

}  // namespace evermap::eval
