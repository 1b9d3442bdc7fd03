#include "core/eval/alignment.h"

#include <Eigen/SVD>

namespace evermap::eval {

const char* toString(AlignmentMode mode) {
  switch (mode) {
    case AlignmentMode::kNone: return "none";
    case AlignmentMode::kSE3: return "se3";
    case AlignmentMode::kSim3: return "sim3";
    case AlignmentMode::kFirstPose: return "first";
  }
  return "?";
}

Expected<AlignmentMode> parseAlignmentMode(std::string_view name) {
  if (name == "none") return AlignmentMode::kNone;
  if (name == "se3") return AlignmentMode::kSE3;
  if (name == "sim3") return AlignmentMode::kSim3;
  if (name == "first") return AlignmentMode::kFirstPose;
  return makeError("unknown alignment \"", std::string(name), "\" (expected se3, sim3, first or none)");
}

Expected<AlignmentResult> umeyama(const std::vector<core::Vec3>& src,
                                  const std::vector<core::Vec3>& dst, bool with_scale) {
  using core::Mat3;
  using core::Vec3;
  if (src.size() != dst.size()) {
    return makeError("alignment: ", src.size(), " estimated positions but ", dst.size(),
                     " ground-truth positions");
  }
  const size_t n = src.size();
  if (n < 3) return makeError("alignment: needs at least 3 matched poses, got ", n);
  Vec3 mu_x = Vec3::Zero();
  Vec3 mu_y = Vec3::Zero();
  for (size_t i = 0; i < n; ++i) {
    if (!src[i].allFinite() || !dst[i].allFinite()) {
      return makeError("alignment: pair ", i, " is not finite");
    }
    mu_x += src[i];
    mu_y += dst[i];
  }
  mu_x /= static_cast<double>(n);
  mu_y /= static_cast<double>(n);
  // eq. (36)-(38): variance of the source and cross-covariance Σxy = (1/n) Σ (y-μy)(x-μx)ᵀ.
  double sigma2_x = 0.0;
  Mat3 sigma_xy = Mat3::Zero();
  for (size_t i = 0; i < n; ++i) {
    const Vec3 dx = src[i] - mu_x;
    sigma2_x += dx.squaredNorm();
    sigma_xy += (dst[i] - mu_y) * dx.transpose();
  }
  sigma2_x /= static_cast<double>(n);
  sigma_xy /= static_cast<double>(n);
  if (with_scale && !(sigma2_x > 1e-18)) {
    return makeError(
        "alignment: the estimated positions are all the same point; the scale is "
        "undefined");
  }

  Eigen::JacobiSVD<Mat3> svd(sigma_xy, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Mat3& U = svd.matrixU();
  const Mat3& V = svd.matrixV();
  const Vec3 d = svd.singularValues();  // descending
  // eq. (39)/(43): S = diag(1, 1, -1) when det(U) det(V) < 0, so that R is a rotation, not
  // a reflection.
  Vec3 s_diag(1.0, 1.0, 1.0);
  if (U.determinant() * V.determinant() < 0.0) s_diag.z() = -1.0;
  const Mat3 R = U * s_diag.asDiagonal() * V.transpose();  // eq. (40)
  // eq. (42): c = tr(D S) / σx².
  const double scale = with_scale ? d.dot(s_diag) / sigma2_x : 1.0;
  const Vec3 t = mu_y - scale * R * mu_x;  // eq. (41)

  AlignmentResult out;
  out.mode = with_scale ? AlignmentMode::kSim3 : AlignmentMode::kSE3;
  out.gt_S_est.scale = scale;
  out.gt_S_est.rigid = core::SE3d(core::SO3d::fromMatrix(R), t);
  out.pairs = n;
  // R is unique iff rank(Σxy) >= 2 (Umeyama, after eq. 40).
  out.rotation_unique = d[1] > 1e-9 * std::max(d[0], 1e-300);
  return out;
}

Expected<AlignmentResult> alignTrajectories(const std::vector<core::SE3d>& gt,
                                            const std::vector<core::SE3d>& est,
                                            AlignmentMode mode) {
  if (gt.size() != est.size()) {
    return makeError("alignment: ", est.size(), " estimated poses but ", gt.size(),
                     " ground-truth poses");
  }
  if (mode == AlignmentMode::kNone) {
    if (gt.empty()) return makeError("alignment: no matched poses");
    AlignmentResult out;
    out.pairs = gt.size();
    return out;
  }
  if (mode == AlignmentMode::kFirstPose) {
    if (gt.empty()) return makeError("alignment: no matched poses");
    AlignmentResult out;
    out.mode = mode;
    out.pairs = gt.size();
    out.gt_S_est.rigid = gt.front() * est.front().inverse();
    return out;
  }
  std::vector<core::Vec3> src;
  std::vector<core::Vec3> dst;
  src.reserve(est.size());
  dst.reserve(gt.size());
  for (size_t i = 0; i < gt.size(); ++i) {
    src.push_back(est[i].translation());
    dst.push_back(gt[i].translation());
  }
  return umeyama(src, dst, mode == AlignmentMode::kSim3);
}

}  // namespace evermap::eval
