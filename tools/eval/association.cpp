#include "tools/eval/association.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "core/common/number_text.h"

namespace evermap::eval {
namespace {

std::string span(const Trajectory& t) {
  char buf[96];
  std::snprintf(buf, sizeof(buf), "[%.3f, %.3f] s", t.poses.front().t_ns * 1e-9,
                t.poses.back().t_ns * 1e-9);
  return buf;
}

}  // namespace

Status AssociationOptions::validate() const {
  if (!(max_dt_s >= 0.0) || !std::isfinite(max_dt_s)) {
    return makeError("max_dt_s must be finite and >= 0, got ", numberText(max_dt_s));
  }
  return Ok{};
}

Expected<Association> associate(const Trajectory& gt, const Trajectory& est,
                                const AssociationOptions& options) {
  if (Status s = options.validate(); !s) return s.error();
  if (Status s = validate(gt); !s) return s.error();
  if (Status s = validate(est); !s) return s.error();
  const auto max_dt_ns = static_cast<int64_t>(std::llround(options.max_dt_s * 1e9));

  // Nearest ground-truth pose for every estimated pose (stamps are strictly increasing).
  constexpr size_t kNone = std::numeric_limits<size_t>::max();
  std::vector<size_t> nearest(est.size(), kNone);
  std::vector<int64_t> gap(est.size(), 0);
  for (size_t i = 0; i < est.size(); ++i) {
    const int64_t t = est.poses[i].t_ns;
    auto it = std::lower_bound(gt.poses.begin(), gt.poses.end(), t,
                               [](const StampedPose& p, int64_t v) { return p.t_ns < v; });
    size_t best = kNone;
    int64_t best_gap = std::numeric_limits<int64_t>::max();
    for (auto c : {it, it == gt.poses.begin() ? gt.poses.end() : std::prev(it)}) {
      if (c == gt.poses.end()) continue;
      const int64_t g = std::abs(c->t_ns - t);
      if (g < best_gap) {
        best_gap = g;
        best = static_cast<size_t>(c - gt.poses.begin());
      }
    }
    if (best != kNone && best_gap <= max_dt_ns) {
      nearest[i] = best;
      gap[i] = best_gap;
    }
  }
  // Because both stamp sequences increase, the nearest indices do not decrease, so estimates
  // competing for one ground-truth pose are neighbours: keep the nearest of each run.
  Association out;
  out.gt_poses = gt.size();
  out.est_poses = est.size();
  double sum_dt = 0.0;
  for (size_t i = 0; i < est.size(); ++i) {
    if (nearest[i] == kNone) continue;
    if (!out.gt_index.empty() && out.gt_index.back() == nearest[i]) {
      if (gap[i] >= gap[out.est_index.back()]) continue;
      // This one is nearer: it replaces the previous pair.
      sum_dt -= gap[out.est_index.back()] * 1e-9;
      out.gt_index.pop_back();
      out.est_index.pop_back();
    }
    out.gt_index.push_back(nearest[i]);
    out.est_index.push_back(i);
    sum_dt += gap[i] * 1e-9;
  }
  if (out.gt_index.empty()) {
    char dt[32];
    std::snprintf(dt, sizeof(dt), "%g", options.max_dt_s);
    return makeError("no pose of ", est.source, " ", span(est), " lies within ", dt,
                     " s of a pose of ", gt.source, " ", span(gt),
                     ": the files do not overlap in time (or need --max-dt / --gt-times)");
  }
  for (size_t k = 0; k < out.gt_index.size(); ++k) {
    const StampedPose& g = gt.poses[out.gt_index[k]];
    out.t_ns.push_back(g.t_ns);
    out.gt.push_back(g.world_T_body);
    out.est.push_back(est.poses[out.est_index[k]].world_T_body);
    out.max_abs_dt_s = std::max(out.max_abs_dt_s, gap[out.est_index[k]] * 1e-9);
  }
  out.mean_abs_dt_s = sum_dt / static_cast<double>(out.size());
  return out;
}

}  // namespace evermap::eval
