#include "tools/stereo-check/disparity_offset.h"

#include <cmath>
#include <limits>

#include <Eigen/Cholesky>

namespace evermap::core {

namespace {

// Robust cost of one pair under `offset` at the motion that minimises it.
double pairCost(const StereoCamera& camera, const StereoMatchPair& pair, double offset,
                const DisparityOffsetOptions& o) {
  const size_t n = pair.uvd_a.size();
  std::vector<Eigen::Vector3d> ma(n), mb(n), pa(n), pb(n);
  for (size_t i = 0; i < n; ++i) {
    ma[i] = pair.uvd_a[i] + Eigen::Vector3d(0.0, 0.0, offset);
    mb[i] = pair.uvd_b[i] + Eigen::Vector3d(0.0, 0.0, offset);
    const auto xa = camera.backProject(ma[i]), xb = camera.backProject(mb[i]);
    if (!xa || !xb) return std::numeric_limits<double>::infinity();
    pa[i] = *xa;
    pb[i] = *xb;
  }
  const Eigen::Vector3d sigma(o.sigma_uv_px, o.sigma_uv_px, o.sigma_d_px);
  constexpr double kBehind = 100.0;  // sigmas, for a point that leaves the front of a camera
  auto residuals = [&](const SE3d& a_T_b, Eigen::VectorXd* r) {
    r->resize(static_cast<Eigen::Index>(6 * n));
    const SE3d b_T_a = a_T_b.inverse();
    for (size_t i = 0; i < n; ++i) {
      const auto in_a = camera.project(a_T_b * pb[i]);
      const auto in_b = camera.project(b_T_a * pa[i]);
      for (int j = 0; j < 3; ++j) {
        (*r)(Eigen::Index(6 * i + j)) = in_a ? ((*in_a)(j)-ma[i](j)) / sigma(j) : kBehind;
        (*r)(Eigen::Index(6 * i + 3 + j)) = in_b ? ((*in_b)(j)-mb[i](j)) / sigma(j) : kBehind;
      }
    }
  };
  const double k = o.huber_sigmas;
  SE3d T = pair.a_T_b;
  Eigen::VectorXd r0, r1;
  Eigen::MatrixXd J(static_cast<Eigen::Index>(6 * n), 6);
  for (int it = 0; it < o.gauss_newton_iterations; ++it) {
    residuals(T, &r0);
    constexpr double h = 1e-6;  // numerical Jacobian: 6 unknowns, cheap
    for (int c = 0; c < 6; ++c) {
      Vec6 xi = Vec6::Zero();
      xi(c) = h;
      residuals(T * SE3d::exp(xi), &r1);
      J.col(c) = (r1 - r0) / h;
    }
    // Iteratively reweighted least squares for the Huber loss.
    const Eigen::VectorXd w =
        r0.unaryExpr([k](double x) { return std::abs(x) < k ? 1.0 : k / std::abs(x); });
    const Mat6 H = J.transpose() * w.asDiagonal() * J;
    const Vec6 g = J.transpose() * w.cwiseProduct(r0);
    const Vec6 dx = -H.ldlt().solve(g);
    if (!dx.allFinite()) break;
    T = T * SE3d::exp(dx);
    if (dx.norm() < 1e-10) break;
  }
  residuals(T, &r0);
  double cost = 0.0;
  for (Eigen::Index i = 0; i < r0.size(); ++i) {
    const double a = std::abs(r0(i));
    cost += a < k ? 0.5 * a * a : k * (a - 0.5 * k);
  }
  return cost;
}

}  // namespace

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

Expected<DisparityOffsetSummary> estimateDisparityOffset(const StereoCamera& camera,
                                                         const std::vector<StereoMatchPair>& pairs,
                                                         const DisparityOffsetOptions& options) {
  if (Status s = options.validate(); !s) return s.error();
  DisparityOffsetSummary summary;
  for (const auto& p : pairs) {
    if (p.uvd_a.size() != p.uvd_b.size()) {
      return makeError("disparity offset: a pair has ", p.uvd_a.size(), " points in a and ",
                       p.uvd_b.size(), " in b");
    }
    if (p.uvd_a.empty()) continue;
    ++summary.pairs;
    summary.matches += static_cast<int>(p.uvd_a.size());
  }
  if (summary.matches == 0) return makeError("disparity offset: no matches");
  const int steps = static_cast<int>(
      std::floor((options.max_offset_px - options.min_offset_px) / options.step_px + 1e-9));
  size_t best = 0;
  for (int s = 0; s <= steps; ++s) {
    const double offset = options.min_offset_px + s * options.step_px;
    double cost = 0.0;
    for (const auto& p : pairs) {
      if (!p.uvd_a.empty()) cost += pairCost(camera, p, offset, options);
    }
    if (!std::isfinite(cost)) continue;  // some disparity + offset <= 0
    summary.curve.emplace_back(offset, cost);
    if (cost < summary.curve[best].second) best = summary.curve.size() - 1;
  }
  if (summary.curve.empty())
    return makeError("disparity offset: every candidate makes some disparity <= 0");
  if (best == 0 || best + 1 == summary.curve.size()) {
    return makeError("disparity offset: least cost at the end of the grid (",
                     summary.curve[best].first, " px); widen [min_offset_px, max_offset_px]");
  }
  // Parabola through the least cost and its two neighbours.
  const double c0 = summary.curve[best - 1].second, c1 = summary.curve[best].second,
               c2 = summary.curve[best + 1].second;
  const double denom = c0 - 2.0 * c1 + c2;
  const double shift = denom > 0.0 ? 0.5 * (c0 - c2) / denom : 0.0;
  summary.offset_px = summary.curve[best].first + shift * options.step_px;
  summary.message =
      makeError("disparity offset ", summary.offset_px, " px (true = measured + offset) from ",
                summary.pairs, " pairs, ", summary.matches, " matches")
          .message;
  return summary;
}

}  // namespace evermap::core
