#include "core/registration/disparity_offset.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include <Eigen/Cholesky>

namespace evermap::core {

namespace {

// Whitened residuals of a pair under (a_T_b, offset): b's points projected into a and a's
// into b, (u, v, d) each; false when some disparity + offset does not back-project.
bool pairResiduals(const StereoCamera& camera, const StereoMatchPair& pair, const SE3d& a_T_b,
                   double offset, const DisparityOffsetOptions& o, Eigen::VectorXd* r) {
  const size_t n = pair.uvd_a.size();
  const Eigen::Vector3d sigma(o.sigma_uv_px, o.sigma_uv_px, o.sigma_d_px);
  const Eigen::Vector3d shift(0.0, 0.0, offset);
  constexpr double kBehind = 100.0;  // sigmas, for a point that leaves the front of a camera
  r->resize(static_cast<Eigen::Index>(6 * n));
  const SE3d b_T_a = a_T_b.inverse();
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d ma = pair.uvd_a[i] + shift, mb = pair.uvd_b[i] + shift;
    const auto pa = camera.backProject(ma), pb = camera.backProject(mb);
    if (!pa || !pb) return false;
    const auto in_a = camera.project(a_T_b * *pb);
    const auto in_b = camera.project(b_T_a * *pa);
    for (int j = 0; j < 3; ++j) {
      (*r)(Eigen::Index(6 * i + j)) = in_a ? ((*in_a)(j)-ma(j)) / sigma(j) : kBehind;
      (*r)(Eigen::Index(6 * i + 3 + j)) = in_b ? ((*in_b)(j)-mb(j)) / sigma(j) : kBehind;
    }
  }
  return true;
}

Eigen::VectorXd huberWeights(const Eigen::VectorXd& r, double k) {
  return r.unaryExpr([k](double x) { return std::abs(x) < k ? 1.0 : k / std::abs(x); });
}

double huberCost(const Eigen::VectorXd& r, double k) {
  double cost = 0.0;
  for (Eigen::Index i = 0; i < r.size(); ++i) {
    const double a = std::abs(r(i));
    cost += a < k ? 0.5 * a * a : k * (a - 0.5 * k);
  }
  return cost;
}

// Robust cost of one pair under `offset` at the motion that minimises it.
double pairCost(const StereoCamera& camera, const StereoMatchPair& pair, double offset,
                const DisparityOffsetOptions& o) {
  const size_t n = pair.uvd_a.size();
  auto residuals = [&](const SE3d& a_T_b, Eigen::VectorXd* r) {
    return pairResiduals(camera, pair, a_T_b, offset, o, r);
  };
  const double k = o.huber_sigmas;
  SE3d T = pair.a_T_b;
  Eigen::VectorXd r0, r1;
  Eigen::MatrixXd J(static_cast<Eigen::Index>(6 * n), 6);
  if (!residuals(T, &r0)) return std::numeric_limits<double>::infinity();
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
    const Eigen::VectorXd w = huberWeights(r0, k);
    const Mat6 H = J.transpose() * w.asDiagonal() * J;
    const Vec6 g = J.transpose() * w.cwiseProduct(r0);
    const Vec6 dx = -H.ldlt().solve(g);
    if (!dx.allFinite()) break;
    T = T * SE3d::exp(dx);
    if (dx.norm() < 1e-10) break;
  }
  if (!residuals(T, &r0)) return std::numeric_limits<double>::infinity();
  return huberCost(r0, k);
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

Expected<OffsetEvidence> pairOffsetEvidence(const StereoCamera& camera, const StereoMatchPair& pair,
                                            const DisparityOffsetOptions& o) {
  if (Status s = o.validate(); !s) return s.error();
  const size_t n = pair.uvd_a.size();
  if (n < 7 || pair.uvd_b.size() != n) {
    return makeError("disparity offset: a pair of ", n, " and ", pair.uvd_b.size(),
                     " points (need 7 in both)");
  }
  using Vec7 = Eigen::Matrix<double, 7, 1>;
  using Mat7 = Eigen::Matrix<double, 7, 7>;
  const double k = o.huber_sigmas;
  SE3d T = pair.a_T_b;
  double offset = 0.0;
  Eigen::VectorXd r0, r1, w;
  Eigen::MatrixXd J(static_cast<Eigen::Index>(6 * n), 7);
  Mat7 H = Mat7::Zero();
  auto linearise = [&]() -> bool {
    if (!pairResiduals(camera, pair, T, offset, o, &r0)) return false;
    constexpr double h = 1e-6;  // numerical Jacobian: 7 unknowns
    for (int c = 0; c < 7; ++c) {
      Vec6 xi = Vec6::Zero();
      if (c < 6) xi(c) = h;
      if (!pairResiduals(camera, pair, T * SE3d::exp(xi), offset + (c == 6 ? h : 0.0), o, &r1)) {
        return false;
      }
      J.col(c) = (r1 - r0) / h;
    }
    w = huberWeights(r0, k);
    H = J.transpose() * w.asDiagonal() * J;
    return true;
  };
  for (int it = 0; it < o.gauss_newton_iterations; ++it) {
    if (!linearise()) return makeError("disparity offset: a disparity + offset is not positive");
    const Vec7 dx = -H.ldlt().solve(J.transpose() * w.cwiseProduct(r0));
    if (!dx.allFinite()) return makeError("disparity offset: the pair's normal matrix is singular");
    T = T * SE3d::exp(Vec6(dx.head<6>()));
    offset += dx(6);
    if (dx.norm() < 1e-10) break;
  }
  if (!linearise()) return makeError("disparity offset: a disparity + offset is not positive");
  const Mat7 cov = H.inverse();
  const double dof = static_cast<double>(r0.size()) - 7.0;
  const double variance_factor = w.dot(r0.cwiseProduct(r0)) / dof;
  const double variance = 2.0 * variance_factor * cov(6, 6);
  if (!(variance > 0.0) || !std::isfinite(variance) || !std::isfinite(offset)) {
    return makeError("disparity offset: the pair does not determine it (no translation?)");
  }
  return OffsetEvidence{offset, std::sqrt(variance), static_cast<int>(n)};
}

Status DisparityOffsetTracker::Options::validate() const {
  if (Status s = estimate.validate(); !s) return s;
  if (min_matches < 7 || min_pairs < 2) {
    return makeError("disparity offset tracker: min_matches ", min_matches, " < 7 or min_pairs ",
                     min_pairs, " < 2");
  }
  if (!(converged_sigma_px > 0.0 && significance_sigmas > 0.0 && max_abs_offset_px > 0.0)) {
    return makeError(
        "disparity offset tracker: converged_sigma_px, significance_sigmas and max_abs_offset_px "
        "must be positive");
  }
  return Ok{};
}

bool DisparityOffsetTracker::add(const StereoCamera& camera, const StereoMatchPair& pair) {
  if (converged_ || static_cast<int>(pair.uvd_a.size()) < options_.min_matches) return false;
  const auto e = pairOffsetEvidence(camera, pair, options_.estimate);
  if (!e || std::abs(e->offset_px) > options_.max_abs_offset_px) return false;
  evidence_.push_back(*e);
  combine();
  return true;
}

void DisparityOffsetTracker::combine() {
  // Inverse-variance mean; its sigma inflated by the scatter of the pairs when they disagree
  // more than their own sigmas allow (the Birge ratio): pairs that share frames, or a scene
  // whose error is not the pairs' noise, are not taken as more evidence than they are.
  double sw = 0.0, swx = 0.0;
  for (const OffsetEvidence& e : evidence_) {
    const double wi = 1.0 / (e.sigma_px * e.sigma_px);
    sw += wi;
    swx += wi * e.offset_px;
  }
  offset_px_ = swx / sw;
  double chi2 = 0.0;
  for (const OffsetEvidence& e : evidence_) {
    const double d = (e.offset_px - offset_px_) / e.sigma_px;
    chi2 += d * d;
  }
  const double n = static_cast<double>(evidence_.size());
  const double birge2 = n > 1.0 ? chi2 / (n - 1.0) : 1.0;
  sigma_px_ = std::sqrt(std::max(1.0, birge2) / sw);
  converged_ = pairs() >= options_.min_pairs && sigma_px_ <= options_.converged_sigma_px;
}

bool DisparityOffsetTracker::significant() const {
  return converged_ && std::abs(offset_px_) >= options_.significance_sigmas * sigma_px_;
}

std::string DisparityOffsetTracker::describe() const {
  int matches = 0;
  for (const OffsetEvidence& e : evidence_) matches += e.matches;
  char buf[200];
  std::snprintf(buf, sizeof buf, "disparity offset %+.3f px +- %.3f (%d pairs, %d matches)%s",
                offset_px_, sigma_px_, pairs(), matches,
                !converged_     ? ": not converged"
                : significant() ? ": converged, applied"
                                : ": converged, within its uncertainty of 0, not applied");
  return buf;
}

}  // namespace evermap::core
