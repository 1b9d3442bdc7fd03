#include "core/geometry/umeyama.h"

#include <algorithm>

#include <Eigen/SVD>

namespace evermap::core {

Expected<UmeyamaFit> umeyama(const std::vector<Vec3>& src, const std::vector<Vec3>& dst,
                             bool with_scale) {
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

  UmeyamaFit out;
  out.dst_S_src.scale = scale;
  out.dst_S_src.rigid = SE3d(SO3d::fromMatrix(R), t);
  out.pairs = n;
  // R is unique iff rank(Σxy) >= 2 (Umeyama, after eq. 40).
  out.rotation_unique = d[1] > 1e-9 * std::max(d[0], 1e-300);
  return out;
}

}  // namespace evermap::core
