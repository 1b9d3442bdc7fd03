#pragma once
// One evaluation of an estimated trajectory against ground truth, as evermap-eval runs it:
// associate by stamp, align (Umeyama SE(3)/Sim(3) or none), then ATE, RPE and optionally the
// KITTI drift, all on the aligned estimate. RPE and drift do not change under an SE(3)
// alignment; under Sim(3) they see the corrected scale, as for monocular estimates.

#include <optional>
#include <string>
#include <vector>

#include "core/common/expected.h"
#include "tools/eval/alignment.h"
#include "tools/eval/association.h"
#include "tools/eval/kitti_drift.h"
#include "tools/eval/metrics.h"
#include "tools/eval/trajectory.h"

namespace evermap::eval {

struct EvaluationOptions {
  AssociationOptions association;
  AlignmentMode alignment = AlignmentMode::kSE3;
  RpeOptions rpe;            // default: over 1 matched pose
  bool kitti_drift = false;  // the drift needs > 100 m of matched path: off by default
  KittiDriftOptions drift;

  Status validate() const;
  // One line, e.g. "align=se3 max_dt=0.02s rpe=1frames kitti_drift=off".
  std::string describe() const;
};

struct EvaluationReport {
  EvaluationOptions options;
  std::string gt_source;
  std::string est_source;
  std::string gt_format;  // left empty by evaluate(); the caller may name the formats
  std::string est_format;
  size_t gt_poses = 0;
  size_t est_poses = 0;
  double gt_path_m = 0.0;   // along the matched ground-truth poses
  double est_path_m = 0.0;  // along the matched, aligned estimate

  size_t pairs = 0;
  double max_abs_dt_s = 0.0;
  double mean_abs_dt_s = 0.0;
  AlignmentResult alignment;
  AteSummary ate;
  RpeSummary rpe;
  std::optional<KittiDriftSummary> drift;

  // Positions for a figure: the ground truth between the first and the last matched pose,
  // and the whole estimate moved by the alignment into the ground-truth frame.
  std::vector<core::Vec3> gt_positions;
  std::vector<core::Vec3> est_positions_aligned;
};

// Errors name the input at fault: invalid trajectories, no overlap in time, too few pairs for
// the alignment, RPE step or drift segments longer than the matched path.
Expected<EvaluationReport> evaluate(const Trajectory& gt, const Trajectory& est,
                                    const EvaluationOptions& options);

}  // namespace evermap::eval
