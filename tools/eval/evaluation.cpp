#include "tools/eval/evaluation.h"

#include "core/common/number_text.h"

namespace evermap::eval {

Status EvaluationOptions::validate() const {
  if (Status s = association.validate(); !s) return s;
  if (Status s = rpe.validate(); !s) return s;
  if (kitti_drift) {
    if (Status s = drift.validate(); !s) return s;
  }
  return Ok{};
}

std::string EvaluationOptions::describe() const {
  std::string s = std::string("align=") + toString(alignment) +
                  " max_dt=" + numberText(association.max_dt_s) + "s rpe=";
  s += rpe.byDistance() ? numberText(rpe.delta_distance_m) + "m"
                        : std::to_string(rpe.delta_frames) + "frames";
  s += kitti_drift ? " kitti_drift=on" : " kitti_drift=off";
  return s;
}

Expected<EvaluationReport> evaluate(const Trajectory& gt, const Trajectory& est,
                                    const EvaluationOptions& options) {
  if (Status s = options.validate(); !s) return s.error();
  auto matched = associate(gt, est, options.association);
  if (!matched) return matched.error();
  const Association& m = *matched;

  auto alignment = alignTrajectories(m.gt, m.est, options.alignment);
  if (!alignment) {
    return makeError(est.source, " against ", gt.source, ": ", alignment.error().message);
  }
  std::vector<core::SE3d> est_aligned;
  est_aligned.reserve(m.size());
  for (const core::SE3d& e : m.est) est_aligned.push_back(alignment->gt_S_est * e);

  EvaluationReport r;
  r.options = options;
  r.gt_source = gt.source;
  r.est_source = est.source;
  r.gt_poses = gt.size();
  r.est_poses = est.size();
  r.pairs = m.size();
  r.max_abs_dt_s = m.max_abs_dt_s;
  r.mean_abs_dt_s = m.mean_abs_dt_s;
  r.alignment = *alignment;
  const std::vector<double> gt_dist = cumulativeDistances(m.gt);
  const std::vector<double> est_dist = cumulativeDistances(est_aligned);
  r.gt_path_m = gt_dist.back();
  r.est_path_m = est_dist.back();

  auto ate = computeAte(m.gt, est_aligned);
  if (!ate) return makeError(est.source, ": ", ate.error().message);
  r.ate = std::move(ate.value());
  auto rpe = computeRpe(m.gt, est_aligned, options.rpe);
  if (!rpe) return makeError(est.source, " against ", gt.source, ": ", rpe.error().message);
  r.rpe = *rpe;
  if (options.kitti_drift) {
    auto drift = computeKittiDrift(m.gt, est_aligned, options.drift);
    if (!drift) return makeError(est.source, " against ", gt.source, ": ", drift.error().message);
    r.drift = std::move(drift.value());
  }

  // The ground truth over the time the estimate covers: a VO run over a part of a long
  // sequence is drawn against that part only.
  const int64_t t_first = m.t_ns.front(), t_last = m.t_ns.back();
  for (const StampedPose& p : gt.poses) {
    if (p.t_ns >= t_first && p.t_ns <= t_last)
      r.gt_positions.push_back(p.world_T_body.translation());
  }
  r.est_positions_aligned.reserve(est.size());
  for (const StampedPose& p : est.poses) {
    r.est_positions_aligned.push_back(alignment->gt_S_est * p.world_T_body.translation());
  }
  return r;
}

}  // namespace evermap::eval
