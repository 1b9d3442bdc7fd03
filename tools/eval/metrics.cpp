#include "tools/eval/metrics.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <numbers>

#include "core/common/number_text.h"

namespace evermap::eval {
namespace {

constexpr double kRadToDeg = 180.0 / std::numbers::pi;

Status checkPairs(const std::vector<core::SE3d>& gt, const std::vector<core::SE3d>& est) {
  if (gt.size() != est.size()) {
    return makeError("metrics: ", est.size(), " estimated poses but ", gt.size(),
                     " ground-truth poses");
  }
  if (gt.empty()) return makeError("metrics: no matched poses");
  for (size_t i = 0; i < gt.size(); ++i) {
    if (!gt[i].translation().allFinite() || !est[i].translation().allFinite() ||
        !gt[i].quaternion().coeffs().allFinite() || !est[i].quaternion().coeffs().allFinite()) {
      return makeError("metrics: matched pose ", i, " is not finite");
    }
  }
  return Ok{};
}

}  // namespace

ErrorStats computeStats(std::vector<double> errors) {
  if (errors.empty()) {
    std::fprintf(stderr, "evermap: computeStats called with no errors\n");
    std::abort();
  }
  ErrorStats s;
  s.count = errors.size();
  const double n = static_cast<double>(errors.size());
  double sum = 0.0;
  double sum_sq = 0.0;
  for (double e : errors) {
    sum += e;
    sum_sq += e * e;
  }
  s.mean = sum / n;
  s.rmse = std::sqrt(sum_sq / n);
  double var = 0.0;
  for (double e : errors) var += (e - s.mean) * (e - s.mean);
  s.std = std::sqrt(var / n);
  std::sort(errors.begin(), errors.end());
  s.min = errors.front();
  s.max = errors.back();
  const size_t mid = errors.size() / 2;
  s.median = errors.size() % 2 == 1 ? errors[mid] : 0.5 * (errors[mid - 1] + errors[mid]);
  return s;
}

Expected<AteSummary> computeAte(const std::vector<core::SE3d>& gt,
                                const std::vector<core::SE3d>& est) {
  if (Status s = checkPairs(gt, est); !s) return s.error();
  AteSummary out;
  std::vector<double> rot_deg;
  out.translation_errors_m.reserve(gt.size());
  rot_deg.reserve(gt.size());
  for (size_t i = 0; i < gt.size(); ++i) {
    out.translation_errors_m.push_back((gt[i].translation() - est[i].translation()).norm());
    rot_deg.push_back(core::rotationAngle(gt[i].so3().inverse() * est[i].so3()) * kRadToDeg);
  }
  out.translation_m = computeStats(out.translation_errors_m);
  out.rotation_deg = computeStats(std::move(rot_deg));
  return out;
}

Status RpeOptions::validate() const {
  const bool frames = delta_frames > 0;
  const bool distance = delta_distance_m > 0.0 && std::isfinite(delta_distance_m);
  if (frames == distance) {
    return makeError(
        "RPE: give exactly one of delta_frames (> 0) and delta_distance_m (> 0), "
        "got ",
        delta_frames, " frames and ", numberText(delta_distance_m), " m");
  }
  if (delta_distance_m < 0.0 || std::isnan(delta_distance_m)) {
    return makeError("RPE: delta_distance_m must be >= 0, got ", numberText(delta_distance_m));
  }
  return Ok{};
}

std::vector<double> cumulativeDistances(const std::vector<core::SE3d>& poses) {
  std::vector<double> d(poses.size(), 0.0);
  for (size_t k = 1; k < poses.size(); ++k) {
    d[k] = d[k - 1] + (poses[k].translation() - poses[k - 1].translation()).norm();
  }
  return d;
}

Expected<RpeSummary> computeRpe(const std::vector<core::SE3d>& gt,
                                const std::vector<core::SE3d>& est, const RpeOptions& options) {
  if (Status s = options.validate(); !s) return s.error();
  if (Status s = checkPairs(gt, est); !s) return s.error();
  std::vector<double> trans_m;
  std::vector<double> rot_deg;
  const std::vector<double> dist = cumulativeDistances(gt);
  size_t j = 0;
  for (size_t i = 0; i < gt.size(); ++i) {
    if (options.byDistance()) {
      // The first pose at least Δ metres further on; j only moves forward as i does.
      j = std::max(j, i + 1);
      while (j < gt.size() && dist[j] - dist[i] < options.delta_distance_m) ++j;
    } else {
      j = i + static_cast<size_t>(options.delta_frames);
    }
    if (j >= gt.size()) break;
    // eq. (3): E = (Q_i⁻¹ Q_j)⁻¹ (P_i⁻¹ P_j).
    const core::SE3d E = core::between(core::between(gt[i], gt[j]), core::between(est[i], est[j]));
    trans_m.push_back(E.translation().norm());
    rot_deg.push_back(core::rotationAngle(E.so3()) * kRadToDeg);
  }
  if (trans_m.empty()) {
    if (options.byDistance()) {
      return makeError("RPE: no pose pair is ", numberText(options.delta_distance_m),
                       " m apart along the ground truth (its matched path is ",
                       numberText(dist.back(), 4), " m long)");
    }
    return makeError("RPE: a step of ", options.delta_frames, " frames needs more than ",
                     options.delta_frames, " matched poses, got ", gt.size());
  }
  RpeSummary out;
  out.options = options;
  out.translation_m = computeStats(std::move(trans_m));
  out.rotation_deg = computeStats(std::move(rot_deg));
  return out;
}

}  // namespace evermap::eval
