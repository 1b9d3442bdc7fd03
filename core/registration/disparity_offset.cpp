#include "core/registration/disparity_offset.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <tuple>

#include <Eigen/Cholesky>

#include "core/camera/rolling_shutter.h"

namespace evermap::core {

namespace {

// Robust cost of one pair under a disparity `offset` and a further rolling-shutter
// `line_delay_s` at the motion that minimises it, the solve started from *T and its result
// left there (the next candidate's start).
double pairCost(const StereoCamera& camera, const StereoMatchPair& pair, double offset,
                double line_delay_s, const DisparityOffsetOptions& o, SE3d* T) {
  const size_t n = pair.uvd_a.size();
  std::vector<Eigen::Vector3d> ma(n), mb(n), pa(n), pb(n);
  const Eigen::Vector3d shift(0.0, 0.0, offset);
  for (size_t i = 0; i < n; ++i) {
    const auto ca = toMiddleRow(camera, pair.uvd_a[i] + shift, pair.omega_a, line_delay_s);
    const auto cb = toMiddleRow(camera, pair.uvd_b[i] + shift, pair.omega_b, line_delay_s);
    if (!ca || !cb) return std::numeric_limits<double>::infinity();
    ma[i] = *ca;
    mb[i] = *cb;
    const auto xa = camera.backProject(ma[i]), xb = camera.backProject(mb[i]);
    if (!xa || !xb) return std::numeric_limits<double>::infinity();
    pa[i] = *xa;
    pb[i] = *xb;
  }
  const Eigen::Vector3d sigma(o.sigma_uv_px, o.sigma_uv_px, o.sigma_d_px);
  constexpr double kBehind = 100.0;  // sigmas, for a point that leaves the front of a camera
  const double k = o.huber_sigmas;
  // Residuals (b's points projected into a, a's into b, whitened) with their Jacobians with
  // respect to the right perturbation a_T_b exp(xi), xi = (v, w):
  //   d(a_T_b exp(xi) p_b)/dxi = R [I, -[p_b]x],   d(exp(-xi) b_T_a p_a)/dxi = [-I, [q]x].
  auto solve = [&](const SE3d& a_T_b, Mat6* H, Vec6* g) {
    const SE3d b_T_a = a_T_b.inverse();
    const Eigen::Matrix3d R = a_T_b.rotationMatrix();
    double cost = 0.0;
    auto add = [&](const std::optional<Eigen::Vector3d>& uvd, const Eigen::Vector3d& measured,
                   const Eigen::Matrix3d& Jp, const Eigen::Matrix<double, 3, 6>& dq) {
      Eigen::Vector3d r = Eigen::Vector3d::Constant(kBehind);
      if (uvd) r = ((*uvd) - measured).cwiseQuotient(sigma);
      for (int j = 0; j < 3; ++j) {
        const double x = std::abs(r(j));
        cost += x < k ? 0.5 * x * x : k * (x - 0.5 * k);
        if (!uvd || H == nullptr) continue;
        // Iteratively reweighted least squares for the Huber loss.
        const double w = x < k ? 1.0 : k / x;
        const Eigen::Matrix<double, 1, 6> row = Jp.row(j) * dq / sigma(j);
        *H += w * row.transpose() * row;
        *g += w * row.transpose() * r(j);
      }
    };
    for (size_t i = 0; i < n; ++i) {
      Eigen::Matrix3d Jp;
      Eigen::Matrix<double, 3, 6> dq;
      dq << R, -R * hat(pb[i]);
      add(camera.project(a_T_b * pb[i], &Jp), ma[i], Jp, dq);
      const Eigen::Vector3d q = b_T_a * pa[i];
      dq << -Eigen::Matrix3d::Identity(), hat(q);
      add(camera.project(q, &Jp), mb[i], Jp, dq);
    }
    return cost;
  };
  for (int it = 0; it < o.gauss_newton_iterations; ++it) {
    Mat6 H = Mat6::Zero();
    Vec6 g = Vec6::Zero();
    solve(*T, &H, &g);
    const Vec6 dx = -H.ldlt().solve(g);
    if (!dx.allFinite()) break;
    *T = *T * SE3d::exp(dx);
    if (dx.norm() < 1e-9) break;
  }
  const double cost = solve(*T, nullptr, nullptr);
  return cost;
}

}  // namespace

StereoMatchPair subsampledPair(const StereoMatchPair& pair, int max_points) {
  const size_t n = pair.uvd_a.size();
  if (n <= static_cast<size_t>(max_points)) return pair;
  StereoMatchPair out;
  out.a_T_b = pair.a_T_b;
  out.omega_a = pair.omega_a;
  out.omega_b = pair.omega_b;
  for (int i = 0; i < max_points; ++i) {
    const size_t k = static_cast<size_t>(i) * n / static_cast<size_t>(max_points);
    out.uvd_a.push_back(pair.uvd_a[k]);
    out.uvd_b.push_back(pair.uvd_b[k]);
  }
  return out;
}

StereoMatchPair matchPair(const KeyframeFeatures& a, const KeyframeFeatures& b,
                          const RegistrationSummary& registration) {
  StereoMatchPair pair;
  if (!registration.ok()) return pair;
  pair.a_T_b = registration.a_T_b;
  for (const auto& [ia, ib] : registration.inliers) {
    pair.uvd_a.emplace_back(a.keypoints[size_t(ia)].x(), a.keypoints[size_t(ia)].y(),
                            a.disparity[size_t(ia)]);
    pair.uvd_b.emplace_back(b.keypoints[size_t(ib)].x(), b.keypoints[size_t(ib)].y(),
                            b.disparity[size_t(ib)]);
  }
  return pair;
}

std::vector<double> evenGrid(double min, double max, double step) {
  const int steps = static_cast<int>(std::floor((max - min) / step + 1e-9));
  std::vector<double> grid;
  for (int s = 0; s <= steps; ++s) grid.push_back(min + s * step);
  return grid;
}

std::vector<double> DisparityOffsetOptions::grid() const {
  return evenGrid(min_offset_px, max_offset_px, step_px);
}

namespace {

// The pair's cost at each candidate (cost(candidate, &T)), swept outwards from the candidate
// nearest 0 (where the registration's motion is the minimum), each solve started from its
// neighbour's motion.
template <typename Cost>
std::vector<double> sweptCurve(const StereoMatchPair& pair, const std::vector<double>& candidates,
                               const Cost& cost) {
  std::vector<double> costs(candidates.size(), std::numeric_limits<double>::infinity());
  if (pair.uvd_a.empty() || candidates.empty()) return costs;
  size_t start = 0;
  for (size_t s = 1; s < candidates.size(); ++s) {
    if (std::abs(candidates[s]) < std::abs(candidates[start])) start = s;
  }
  SE3d T = pair.a_T_b;
  for (size_t s = start; s < candidates.size(); ++s) costs[s] = cost(candidates[s], &T);
  T = pair.a_T_b;
  for (size_t s = start; s-- > 0;) costs[s] = cost(candidates[s], &T);
  return costs;
}

}  // namespace

std::vector<double> pairCostCurve(const StereoCamera& camera, const StereoMatchPair& pair,
                                  const std::vector<double>& offsets,
                                  const DisparityOffsetOptions& options) {
  return sweptCurve(pair, offsets, [&](double offset, SE3d* T) {
    return pairCost(camera, pair, offset, 0.0, options, T);
  });
}

std::vector<double> pairLineDelayCurve(const StereoCamera& camera, const StereoMatchPair& pair,
                                       const std::vector<double>& line_delays_s,
                                       const DisparityOffsetOptions& options) {
  return sweptCurve(pair, line_delays_s, [&](double delay, SE3d* T) {
    return pairCost(camera, pair, 0.0, delay, options, T);
  });
}

Expected<double> leastCostOffset(const std::vector<double>& offsets,
                                 const std::vector<double>& costs) {
  const auto point = leastCostPoint(offsets, costs);
  if (!point) return point.error();
  return point->first;
}

StereoMatchPair withRowSlope(const StereoMatchPair& pair, double cy, double slope) {
  StereoMatchPair out = pair;
  for (auto* uvd : {&out.uvd_a, &out.uvd_b})
    for (Eigen::Vector3d& m : *uvd) m.z() += slope * (m.y() - cy);
  return out;
}

Expected<std::pair<double, double>> leastCostPoint(const std::vector<double>& offsets,
                                                   const std::vector<double>& costs) {
  size_t best = offsets.size();
  for (size_t s = 0; s < offsets.size() && s < costs.size(); ++s) {
    if (std::isfinite(costs[s]) && (best == offsets.size() || costs[s] < costs[best])) best = s;
  }
  if (best == offsets.size())
    return makeError("disparity offset: every candidate makes some disparity <= 0");
  if (best == 0 || best + 1 == offsets.size() || !std::isfinite(costs[best - 1]) ||
      !std::isfinite(costs[best + 1])) {
    return makeError("disparity offset: least cost at the end of the grid (", offsets[best],
                     " px); widen [min_offset_px, max_offset_px]");
  }
  // Parabola through the least cost and its two neighbours.
  const double c0 = costs[best - 1], c1 = costs[best], c2 = costs[best + 1];
  const double denom = c0 - 2.0 * c1 + c2;
  const double shift = denom > 0.0 ? 0.5 * (c0 - c2) / denom : 0.0;
  const double least = denom > 0.0 ? c1 - (c2 - c0) * (c2 - c0) / (8.0 * denom) : c1;
  return std::make_pair(offsets[best] + shift * (offsets[best + 1] - offsets[best]), least);
}

Status DisparityOffsetOptions::validate() const {
  if (!(std::isfinite(min_offset_px) && std::isfinite(max_offset_px) &&
        min_offset_px < max_offset_px)) {
    return makeError("disparity offset: grid [", min_offset_px, ", ", max_offset_px, "] is empty");
  }
  if (!(step_px > 0.0) || (max_offset_px - min_offset_px) / step_px > 10000.0) {
    return makeError("disparity offset: step_px ", step_px,
                     " is not positive or too fine for the grid");
  }
  if (!(sigma_uv_px > 0.0 && sigma_d_px > 0.0 && huber_sigmas > 0.0)) {
    return makeError("disparity offset: sigma_uv_px, sigma_d_px and huber_sigmas must be positive");
  }
  if (gauss_newton_iterations < 1) {
    return makeError("disparity offset: gauss_newton_iterations ", gauss_newton_iterations, " < 1");
  }
  return Ok{};
}

namespace {

// The pairs and matches in `summary`. Errors: a pair whose frames hold different numbers of
// points, or no match at all.
Status countPairs(const std::vector<StereoMatchPair>& pairs, DisparityOffsetSummary* summary) {
  for (const auto& p : pairs) {
    if (p.uvd_a.size() != p.uvd_b.size()) {
      return makeError("disparity offset: a pair has ", p.uvd_a.size(), " points in a and ",
                       p.uvd_b.size(), " in b");
    }
    if (p.uvd_a.empty()) continue;
    ++summary->pairs;
    summary->matches += static_cast<int>(p.uvd_a.size());
  }
  if (summary->matches == 0) return makeError("disparity offset: no matches");
  return Ok{};
}

}  // namespace

Expected<DisparityOffsetSummary> estimateDisparityOffset(const StereoCamera& camera,
                                                         const std::vector<StereoMatchPair>& pairs,
                                                         const DisparityOffsetOptions& options) {
  if (Status s = options.validate(); !s) return s.error();
  DisparityOffsetSummary summary;
  if (Status s = countPairs(pairs, &summary); !s) return s.error();
  const std::vector<double> offsets = options.grid();
  std::vector<double> total(offsets.size(), 0.0);
  for (const auto& p : pairs) {
    if (p.uvd_a.empty()) continue;
    const std::vector<double> costs = pairCostCurve(camera, p, offsets, options);
    for (size_t s = 0; s < offsets.size(); ++s) total[s] += costs[s];
  }
  for (size_t s = 0; s < offsets.size(); ++s) {
    if (std::isfinite(total[s])) summary.curve.emplace_back(offsets[s], total[s]);
  }
  const Expected<double> best = leastCostOffset(offsets, total);
  if (!best) return best.error();
  summary.offset_px = *best;
  summary.message =
      makeError("disparity offset ", summary.offset_px, " px (true = measured + offset) from ",
                summary.pairs, " pairs, ", summary.matches, " matches")
          .message;
  return summary;
}

Expected<std::pair<double, double>> leastCostProfile(
    const std::vector<double>& grid, const std::vector<double>& rows,
    const std::vector<std::vector<double>>& table) {
  const double inf = std::numeric_limits<double>::infinity();
  std::vector<double> least(rows.size(), inf), at(rows.size(), inf);
  for (size_t r = 0; r < rows.size() && r < table.size(); ++r) {
    if (const auto p = leastCostPoint(grid, table[r])) {
      std::tie(at[r], least[r]) = *p;
      continue;
    }
    // A row whose least cost is at an end of the grid (an extreme row wants a value beyond
    // it): its least candidate, an upper bound of its least cost.
    for (size_t s = 0; s < grid.size() && s < table[r].size(); ++s) {
      if (table[r][s] < least[r]) {
        least[r] = table[r][s];
        at[r] = grid[s];
      }
    }
  }
  const auto m = leastCostPoint(rows, least);
  if (!m) return m.error();
  const double f = (m->first - rows[0]) / (rows[1] - rows[0]);
  const size_t i = std::min(static_cast<size_t>(std::max(0.0, std::floor(f))), rows.size() - 2);
  const double t = f - static_cast<double>(i);
  return std::make_pair(m->first, at[i] + t * (at[i + 1] - at[i]));
}

Expected<DisparityPlaneSummary> estimateDisparityPlane(const StereoCamera& camera,
                                                       const std::vector<StereoMatchPair>& pairs,
                                                       const DisparityOffsetOptions& options,
                                                       const std::vector<double>& slopes) {
  if (Status s = options.validate(); !s) return s.error();
  if (slopes.size() < 3) return makeError("disparity plane: fewer than 3 candidate slopes");
  DisparityOffsetSummary counts;
  if (Status s = countPairs(pairs, &counts); !s) return s.error();
  const std::vector<double> offsets = options.grid();
  std::vector<std::vector<double>> total(slopes.size(), std::vector<double>(offsets.size(), 0.0));
  for (size_t r = 0; r < slopes.size(); ++r) {
    for (const auto& p : pairs) {
      if (p.uvd_a.empty()) continue;
      const std::vector<double> costs =
          pairCostCurve(camera, withRowSlope(p, camera.cy(), slopes[r]), offsets, options);
      for (size_t s = 0; s < offsets.size(); ++s) total[r][s] += costs[s];
    }
  }
  const auto m = leastCostProfile(offsets, slopes, total);
  if (!m) return makeError("disparity plane: ", m.error().message);
  return DisparityPlaneSummary{m->second, m->first};
}

}  // namespace evermap::core
