#include "core/messages/pose_fields.h"

#include <algorithm>
#include <cmath>
#include <string>

#include <Eigen/Eigenvalues>

namespace evermap::messages {

namespace {

// An N x N covariance from a row-major field, symmetrised; an error naming `what` when it is
// not finite or not symmetric positive semi-definite (within rounding).
template <int N>
Expected<Eigen::Matrix<double, N, N>> covarianceOf(const double* row_major, const char* what) {
  using Mat = Eigen::Matrix<double, N, N>;
  for (int i = 0; i < N * N; ++i)
    if (!std::isfinite(row_major[i]))
      return Error(std::string(what) + ": covariance is not finite");
  Mat c;
  for (int r = 0; r < N; ++r)
    for (int k = 0; k < N; ++k) c(r, k) = row_major[N * r + k];
  const double scale = std::max(1e-12, c.diagonal().cwiseAbs().maxCoeff());
  if ((c - c.transpose()).cwiseAbs().maxCoeff() > 1e-9 * scale)
    return Error(std::string(what) + ": covariance is not symmetric");
  const Mat symmetric = 0.5 * (c + c.transpose());
  Eigen::SelfAdjointEigenSolver<Mat> eig(symmetric);
  if (eig.eigenvalues().minCoeff() < -1e-9 * scale)
    return Error(std::string(what) + ": covariance is not positive semi-definite");
  return symmetric;
}

}  // namespace

Expected<core::Mat6> covarianceFromMessage(const double* row_major, const char* what) {
  return covarianceOf<6>(row_major, what);
}

Expected<Eigen::Matrix3d> planarCovarianceFromMessage(const double* row_major, const char* what) {
  return covarianceOf<3>(row_major, what);
}

Expected<Eigen::Quaterniond> quaternionFromMessage(const double* orientation, const char* what) {
  const Eigen::Quaterniond q(orientation[0], orientation[1], orientation[2], orientation[3]);
  if (!q.coeffs().allFinite()) return makeError(what, ": orientation is not finite");
  if (std::abs(q.norm() - 1.0) > kUnitQuaternionTolerance) {
    return makeError(what, ": orientation is not a unit quaternion (norm ", q.norm(), ")");
  }
  return q;
}

Expected<core::SE3d> poseFromMessage(const double* translation, const double* orientation,
                                     const char* what) {
  const core::Vec3 t(translation[0], translation[1], translation[2]);
  if (!t.allFinite()) return makeError(what, ": translation is not finite");
  const Expected<Eigen::Quaterniond> q = quaternionFromMessage(orientation, what);
  if (!q) return q.error();
  return core::SE3d(*q, t);
}

}  // namespace evermap::messages
