#include "core/registration/motion_estimation.h"

#include <algorithm>

#include <cmath>
#include <limits>

#include <Eigen/Dense>

#include "core/geometry/umeyama.h"
#include "core/common/option_fields.h"

namespace evermap::core {

void MotionOptions::declareOptions(OptionList& o) {
  o.add("max_iterations", &max_iterations, "iterations", "Gauss-Newton iterations per solve")
      .min(1);
  o.add("inlier_max_reprojection_px", &inlier_max_reprojection_px, "px",
        "after the first solve, matches with a larger error (either image) are outliers")
      .positive();
  o.add("max_rejection_rounds", &max_rejection_rounds, "solves",
        "graduated rejection: solves until the outlier bound is reached (0: one rejection)")
      .nonNegative();
  o.add("max_mean_reprojection_px", &max_mean_reprojection_px, "px",
        "the final mean error (both directions) at most")
      .positive();
  o.add("min_inliers", &min_inliers, "inliers",
        "fewest inliers a motion is estimated from (>= 3: 6 unknowns)")
      .min(3);
  o.add("pixel_sigma_px", &pixel_sigma_px, "px",
        "lower bound of the pixel noise of the covariance and of the whitening")
      .positive();
  o.add("disparity_sigma_px", &disparity_sigma_px, "px",
        "disparity noise each residual is whitened for (0: points taken as exact)")
      .nonNegative();
  o.add("use_initial_guess", &use_initial_guess,
        "start from the caller's motion instead of the closed form");
}

Status MotionOptions::validate() const { return checkOptionRanges(*this, "motion."); }

const char* toString(MotionStatus status) {
  switch (status) {
    case MotionStatus::kOk:
      return "ok";
    case MotionStatus::kInsufficientInliers:
      return "insufficient inliers";
    case MotionStatus::kOptimizationFailure:
      return "optimization failure";
    case MotionStatus::kReprojectionError:
      return "reprojection error";
  }
  return "?";
}

namespace {

// a_T_b and its inverse as matrices, computed once per evaluation of all the matches.
struct PoseMatrices {
  explicit PoseMatrices(const SE3d& a_T_b)
      : R(a_T_b.rotationMatrix()), t(a_T_b.translation()), Rt(R.transpose()), t_inv(-Rt * t) {}
  Mat3 R;
  Vec3 t;
  Mat3 Rt;
  Vec3 t_inv;
};

using Mat23 = Eigen::Matrix<double, 2, 3>;

// The pixel of a point in front of a camera and, when J is not null, its Jacobian: the first
// two rows of StereoCamera::project, inline and with the same arithmetic (the residuals below
// are the motion estimate's hot loop and need neither the disparity nor its row).
inline bool projectPixel(const StereoCamera& c, const Vec3& p, Eigen::Vector2d* uv, Mat23* J) {
  if (!p.allFinite() || !(p.z() > 0.0)) return false;
  const double iz = 1.0 / p.z();
  *uv = Eigen::Vector2d(c.fx() * p.x() * iz + c.cx(), c.fy() * p.y() * iz + c.cy());
  if (J) {
    const double iz2 = iz * iz;
    *J << c.fx() * iz, 0.0, -c.fx() * p.x() * iz2, 0.0, c.fy() * iz, -c.fy() * p.y() * iz2;
  }
  return true;
}

// J (4x6, optional): d r / d δ. Ja_out, Jb_out (optional): the projection Jacobians at the two
// reprojected points.
inline bool residual(const StereoCamera& camera_a, const StereoCamera& camera_b,
                     const Correspondence& m, const PoseMatrices& T, Eigen::Matrix<double, 4, 1>* r,
                     Eigen::Matrix<double, 4, 6>* J, Mat23* Ja_out = nullptr,
                     Mat23* Jb_out = nullptr) {
  // Into a: q_a = T exp(δ) p_b ≈ T p_b + R (υ + ω × p_b): dq_a/dδ = R [I, -[p_b]x].
  const Vec3 q_a = T.R * m.p_b + T.t;
  // Into b: q_b = exp(-δ) T⁻¹ p_a ≈ q_b - υ - ω × q_b: dq_b/dδ = [-I, [q_b]x].
  const Vec3 q_b = T.Rt * m.p_a + T.t_inv;
  Mat23 Ja, Jb;
  const bool jacobians = J || Ja_out || Jb_out;
  Eigen::Vector2d uv_a, uv_b;
  if (!projectPixel(camera_a, q_a, &uv_a, jacobians ? &Ja : nullptr) ||
      !projectPixel(camera_b, q_b, &uv_b, jacobians ? &Jb : nullptr)) {
    return false;
  }
  r->head<2>() = uv_a - m.uv_a;
  r->tail<2>() = uv_b - m.uv_b;
  if (Ja_out) *Ja_out = Ja;
  if (Jb_out) *Jb_out = Jb;
  if (J) {
    Eigen::Matrix<double, 3, 6> dqa, dqb;
    dqa.leftCols<3>() = T.R;
    dqa.rightCols<3>() = -T.R * hat(m.p_b);
    dqb.leftCols<3>() = -Mat3::Identity();
    dqb.rightCols<3>() = hat(q_b);
    J->topRows<2>() = Ja * dqa;
    J->bottomRows<2>() = Jb * dqb;
  }
  return true;
}

}  // namespace

bool bidirectionalResidual(const StereoCamera& camera_a, const StereoCamera& camera_b,
                           const Correspondence& m, const SE3d& a_T_b,
                           Eigen::Matrix<double, 4, 1>* r, Eigen::Matrix<double, 4, 6>* J) {
  return residual(camera_a, camera_b, m, PoseMatrices(a_T_b), r, J);
}

Eigen::Vector2d reprojectionErrors(const StereoCamera& camera_a, const StereoCamera& camera_b,
                                   const Correspondence& m, const SE3d& a_T_b) {
  Eigen::Matrix<double, 4, 1> r;
  if (!bidirectionalResidual(camera_a, camera_b, m, a_T_b, &r, nullptr)) {
    return Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
  }
  return Eigen::Vector2d(r.head<2>().norm(), r.tail<2>().norm());
}

namespace {

// Whitens one residual of a match for the depth noise of the points they reproject
// (MotionOptions::disparity_sigma_px): a stereo point's depth error moves it along its ray,
// δp = p δz / z with σ_z = z² σ_d / (f b), which moves its reprojection along g = J_π p σ_z / z.
// The residual's covariance σ² I + g gᵀ has the inverse square root
// (1/σ) (I - c ĝ ĝᵀ), c = 1 - 1 / sqrt(1 + |g|² / σ²); applied times σ, the residual stays in
// pixels where the depth does not matter (rotation, points near the epipole) and is scaled
// down along the epipolar direction where it does (far points under translation).
// The whitening depends on the pose; the Jacobian holds it fixed. J (rows `row`, `row` + 1)
// may be null: the cost alone.
void whitenAlong(const Eigen::Vector2d& g, double sigma_px,
                 Eigen::Ref<Eigen::Matrix<double, 2, 1>> r, Eigen::Matrix<double, 4, 6>* J,
                 int row) {
  const double g2 = g.squaredNorm();
  if (!(g2 > 1e-12)) return;
  const double c = 1.0 - 1.0 / std::sqrt(1.0 + g2 / (sigma_px * sigma_px));
  const Eigen::Matrix2d W = Eigen::Matrix2d::Identity() - (c / g2) * g * g.transpose();
  r = W * r;
  if (J) J->middleRows<2>(row) = W * J->middleRows<2>(row);
}

struct Problem {
  const StereoCamera& camera_a;
  const StereoCamera& camera_b;
  const std::vector<Correspondence>& matches;
  double disparity_sigma_px = 0.0;  // 0: no whitening
  double pixel_sigma_px = 0.3;

  // Per match (with whitening): σ_z / z of p_a and of p_b, σ_z = z² σ_d / (f b).
  std::vector<Eigen::Vector2d> depth_sigma_over_z;

  double depthSigma(const StereoCamera& c, double z) const {
    return z * z * disparity_sigma_px / (c.fx() * c.baselineM());
  }

  void precompute() {
    if (!(disparity_sigma_px > 0.0)) return;
    depth_sigma_over_z.resize(matches.size());
    for (size_t k = 0; k < matches.size(); ++k) {
      const Correspondence& m = matches[k];
      depth_sigma_over_z[k] = Eigen::Vector2d(depthSigma(camera_a, m.p_a.z()) / m.p_a.z(),
                                              depthSigma(camera_b, m.p_b.z()) / m.p_b.z());
    }
  }

  // The residuals of one match (whitened for depth noise) and, when J is not null, their
  // Jacobian; false when a point falls behind a camera.
  bool whitenedResidual(int i, const PoseMatrices& P, Eigen::Matrix<double, 4, 1>* r,
                        Eigen::Matrix<double, 4, 6>* J) const {
    const Correspondence& m = matches[static_cast<size_t>(i)];
    if (!(disparity_sigma_px > 0.0)) return residual(camera_a, camera_b, m, P, r, J);
    Mat23 Ja, Jb;
    if (!residual(camera_a, camera_b, m, P, r, J, &Ja, &Jb)) return false;
    // The reprojection into a moves with the depth of p_b (δq_a = R p_b δz / z), the one into
    // b with the depth of p_a (δq_b = Rᵀ p_a δz / z).
    const Eigen::Vector2d& k = depth_sigma_over_z[static_cast<size_t>(i)];
    const Eigen::Vector2d ga = Ja * (P.R * m.p_b) * k.y();
    const Eigen::Vector2d gb = Jb * (P.Rt * m.p_a) * k.x();
    whitenAlong(ga, pixel_sigma_px, r->head<2>(), J, 0);
    whitenAlong(gb, pixel_sigma_px, r->tail<2>(), J, 2);
    return true;
  }

  // The errors (pixels, whitened) of one match in image a and image b; +inf behind a camera.
  Eigen::Vector2d errors(const PoseMatrices& P, int i) const {
    Eigen::Matrix<double, 4, 1> r;
    if (!whitenedResidual(i, P, &r, nullptr)) {
      return Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
    }
    return Eigen::Vector2d(r.head<2>().norm(), r.tail<2>().norm());
  }

  // Sum of squared residuals over `active`, and optionally H = JᵀJ, g = Jᵀr. Points behind a
  // camera contribute nothing (they are rejected as outliers afterwards).
  double evaluate(const SE3d& T, const std::vector<int>& active, Mat6* H, Vec6* g) const {
    double cost = 0.0;
    if (H) H->setZero();
    if (g) g->setZero();
    Eigen::Matrix<double, 4, 1> r;
    Eigen::Matrix<double, 4, 6> J;
    const PoseMatrices P(T);
    for (int i : active) {
      if (!whitenedResidual(i, P, &r, H ? &J : nullptr)) continue;
      cost += r.squaredNorm();
      if (H) {
        H->noalias() += J.transpose() * J;
        g->noalias() += J.transpose() * r;
      }
    }
    return cost;
  }

  // Levenberg-Marquardt from T; returns the iterations used, or -1 on a numerical failure.
  int solve(SE3d* T, const std::vector<int>& active, int max_iterations) const {
    double lambda = 1e-4;
    Mat6 H;
    Vec6 g;
    double cost = evaluate(*T, active, &H, &g);
    int it = 0;
    for (; it < max_iterations; ++it) {
      bool improved = false;
      for (int tries = 0; tries < 10 && !improved; ++tries) {
        Mat6 A = H;
        A.diagonal() += lambda * (H.diagonal().array() + 1e-9).matrix();
        const Vec6 delta = A.ldlt().solve(-g);
        if (!delta.allFinite()) return -1;
        // Converged: a step this far below any precision the data has (1e-7 m or rad) is not
        // worth its evaluation; near the minimum, rounding would refuse it try after try.
        if (delta.norm() < 1e-7) return it;
        const SE3d candidate = *T * SE3d::exp(delta);
        const double c = evaluate(candidate, active, nullptr, nullptr);
        if (std::isfinite(c) && c <= cost) {
          *T = candidate;
          lambda = std::max(lambda * 0.1, 1e-9);
          improved = true;
          const bool converged = cost - c < 1e-9 * (cost + 1e-12);  // the cost no longer moves
          cost = evaluate(*T, active, &H, &g);
          if (converged) return it + 1;
        } else {
          lambda *= 10.0;
        }
      }
      if (!improved) break;  // a minimum within numerical precision
    }
    return it;
  }
};

// The starting motion: `initial`, or (use_initial_guess off) the rigid alignment of the
// candidates' points when it exists.
SE3d initialMotion(const std::vector<Correspondence>& matches, const std::vector<int>& candidates,
                   const SE3d& initial, const MotionOptions& options) {
  SE3d T = initial;
  if (!options.use_initial_guess) {
    std::vector<Vec3> src, dst;  // a_T_b maps p_b onto p_a
    src.reserve(candidates.size());
    dst.reserve(candidates.size());
    for (int i : candidates) {
      src.push_back(matches[static_cast<size_t>(i)].p_b);
      dst.push_back(matches[static_cast<size_t>(i)].p_a);
    }
    if (const auto a = core::umeyama(src, dst, /*with_scale=*/false); a.ok()) {
      T = a->dst_S_src.rigid;
    }
  }
  return T;
}

// The error bound of one rejection round, and in *worst the largest error of each active match.
double rejectionBound(const Problem& problem, const SE3d& T, const std::vector<int>& active,
                      int round, double previous_bound, const MotionOptions& options,
                      std::vector<double>* worst) {
  worst->reserve(active.size());
  const PoseMatrices P(T);
  for (int i : active) {
    worst->push_back(problem.errors(P, i).maxCoeff());
  }
  std::vector<double> sorted = *worst;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(sorted.size() / 2),
                   sorted.end());
  // At most half the previous bound: a fit pulled off so far that the median itself is an
  // outlier's error would otherwise keep the same bound.
  const double robust = std::min(3.0 * 1.4826 * sorted[sorted.size() / 2], 0.5 * previous_bound);
  return round >= options.max_rejection_rounds
             ? options.inlier_max_reprojection_px
             : std::max(options.inlier_max_reprojection_px, robust);
}

// Outlier rejection (FOVIS): drop matches beyond the error bound and solve again. When the
// first solve is pulled off by gross outliers (a clique that admits far points with wrong
// depths), the bound starts at a robust multiple of the median error (1.4826 median = σ of
// a normal distribution), at least halves per solve and reaches
// inlier_max_reprojection_px after at most max_rejection_rounds solves. False (and *out
// final) when too few matches stay.
bool rejectOutliers(const Problem& problem, const std::vector<int>& candidates,
                    const MotionOptions& options, SE3d* T, std::vector<int>* active,
                    int* iterations, MotionEstimate* out) {
  const int n_min = options.min_inliers;
  double previous_bound = std::numeric_limits<double>::infinity();
  for (int round = 0; *iterations >= 0; ++round) {
    std::vector<double> worst;
    const double bound =
        rejectionBound(problem, *T, *active, round, previous_bound, options, &worst);
    previous_bound = bound;
    std::vector<int> kept;
    kept.reserve(active->size());
    for (size_t k = 0; k < active->size(); ++k) {
      if (worst[k] <= bound) kept.push_back((*active)[k]);
    }
    active->swap(kept);
    if (static_cast<int>(active->size()) < n_min) {
      out->status = MotionStatus::kInsufficientInliers;
      out->message = makeError(active->size(), " of ", candidates.size(), " matches within ", bound,
                               " px after ", round + 1, " solves, need ", n_min)
                         .message;
      out->a_T_b = *T;
      out->inliers = *active;
      return false;
    }
    const int more = problem.solve(T, *active, options.max_iterations);
    *iterations = more < 0 ? -1 : *iterations + more;
    if (bound <= options.inlier_max_reprojection_px) break;
  }
  return true;
}

// The estimate's reprojection error, covariance and status at the solution T.
void judgeEstimate(const Problem& problem, int iterations, const MotionOptions& options,
                   MotionEstimate* out) {
  const SE3d& T = out->a_T_b;
  const std::vector<int>& active = out->inliers;
  Mat6 H;
  Vec6 g;
  const double cost = problem.evaluate(T, active, &H, &g);
  if (iterations < 0 || !std::isfinite(cost) || !T.translation().allFinite()) {
    out->status = MotionStatus::kOptimizationFailure;
    out->message = "the motion estimate did not stay finite";
    return;
  }
  double sum_error = 0.0;
  const PoseMatrices P(T);
  for (int i : active) {
    sum_error += problem.errors(P, i).sum();
  }
  out->mean_reprojection_px = sum_error / (2.0 * static_cast<double>(active.size()));
  Eigen::FullPivLU<Mat6> lu(H);
  if (!lu.isInvertible() || !H.allFinite()) {
    out->status = MotionStatus::kOptimizationFailure;
    out->message = "the motion is not determined by the inliers (singular normal equations)";
    return;
  }
  // Residual variance per pixel coordinate: 4 residuals per match, 6 unknowns.
  const double dof = std::max(4.0 * static_cast<double>(active.size()) - 6.0, 1.0);
  const double sigma2 = std::max(cost / dof, options.pixel_sigma_px * options.pixel_sigma_px);
  const Mat6 Hinv = lu.inverse();
  out->covariance = 2.0 * sigma2 * 0.5 * (Hinv + Hinv.transpose());
  if (out->mean_reprojection_px > options.max_mean_reprojection_px) {
    out->status = MotionStatus::kReprojectionError;
    out->message = makeError("mean reprojection error ", out->mean_reprojection_px, " px exceeds ",
                             options.max_mean_reprojection_px, " px")
                       .message;
    return;
  }
  out->status = MotionStatus::kOk;
}

}  // namespace

MotionEstimate estimateMotion(const StereoCamera& camera_a, const StereoCamera& camera_b,
                              const std::vector<Correspondence>& matches,
                              const std::vector<int>& candidates, const SE3d& initial,
                              const MotionOptions& options) {
  MotionEstimate out;
  const int n_min = options.min_inliers;
  if (static_cast<int>(candidates.size()) < n_min) {
    out.status = MotionStatus::kInsufficientInliers;
    out.message = makeError(candidates.size(), " candidate matches, need ", n_min).message;
    return out;
  }
  SE3d T = initialMotion(matches, candidates, initial, options);
  Problem problem{camera_a, camera_b, matches, options.disparity_sigma_px, options.pixel_sigma_px,
                  {}};
  problem.precompute();
  std::vector<int> active = candidates;
  int iterations = problem.solve(&T, active, options.max_iterations);
  if (!rejectOutliers(problem, candidates, options, &T, &active, &iterations, &out)) return out;
  out.iterations = std::max(iterations, 0);
  out.a_T_b = T;
  out.inliers = active;
  judgeEstimate(problem, iterations, options, &out);
  return out;
}

}  // namespace evermap::core
