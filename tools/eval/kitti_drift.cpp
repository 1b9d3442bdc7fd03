#include "tools/eval/kitti_drift.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "core/common/number_text.h"
#include "tools/eval/metrics.h"

namespace evermap::eval {

Status KittiDriftOptions::validate() const {
  if (segment_lengths_m.empty()) return makeError("KITTI drift: no segment length");
  for (double L : segment_lengths_m) {
    if (!(L > 0.0) || !std::isfinite(L)) {
      return makeError("KITTI drift: segment lengths must be positive, got ", numberText(L));
    }
  }
  if (step_frames == 0) return makeError("KITTI drift: step_frames must be >= 1");
  return Ok{};
}

Expected<KittiDriftSummary> computeKittiDrift(const std::vector<core::SE3d>& gt,
                                              const std::vector<core::SE3d>& est,
                                              const KittiDriftOptions& options) {
  if (Status s = options.validate(); !s) return s.error();
  if (gt.size() != est.size()) {
    return makeError("KITTI drift: ", est.size(), " estimated poses but ", gt.size(),
                     " ground-truth poses");
  }
  if (gt.size() < 2) return makeError("KITTI drift: needs at least 2 matched poses");
  for (size_t i = 0; i < gt.size(); ++i) {
    if (!gt[i].translation().allFinite() || !est[i].translation().allFinite()) {
      return makeError("KITTI drift: matched pose ", i, " is not finite");
    }
  }
  const std::vector<double> dist = cumulativeDistances(gt);
  constexpr double kRadToDeg = 180.0 / std::numbers::pi;

  KittiDriftSummary out;
  double sum_t = 0.0;
  double sum_r = 0.0;
  for (double L : options.segment_lengths_m) {
    KittiDriftLength row;
    row.length_m = L;
    double row_t = 0.0;
    double row_r = 0.0;
    for (size_t first = 0; first < gt.size(); first += options.step_frames) {
      // lastFrameFromSegmentLength: the first pose strictly more than L further on.
      const auto it = std::upper_bound(dist.begin() + first, dist.end(), dist[first] + L);
      if (it == dist.end()) break;  // later starts have even less path ahead
      const size_t last = static_cast<size_t>(it - dist.begin());
      const core::SE3d delta_gt = core::between(gt[first], gt[last]);
      const core::SE3d delta_est = core::between(est[first], est[last]);
      const core::SE3d E = core::between(delta_est, delta_gt);
      row_t += E.translation().norm() / L;
      row_r += core::rotationAngle(E.so3()) / L;
      ++row.segments;
    }
    if (row.segments > 0) {
      const double n = static_cast<double>(row.segments);
      row.translation_percent = 100.0 * row_t / n;
      row.rotation_deg_per_100m = 100.0 * kRadToDeg * row_r / n;
    }
    out.segments += row.segments;
    sum_t += row_t;
    sum_r += row_r;
    out.per_length.push_back(row);
  }
  if (out.segments == 0) {
    return makeError("KITTI drift: the ground-truth path (", numberText(dist.back(), 4),
                     " m over the matched poses) is shorter than the shortest segment (",
                     numberText(*std::min_element(options.segment_lengths_m.begin(),
                                                  options.segment_lengths_m.end())),
                     " m)");
  }
  const double n = static_cast<double>(out.segments);
  out.translation_percent = 100.0 * sum_t / n;
  out.rotation_deg_per_100m = 100.0 * kRadToDeg * sum_r / n;
  return out;
}

}  // namespace evermap::eval
