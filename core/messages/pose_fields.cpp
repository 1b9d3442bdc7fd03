#include "core/messages/pose_fields.h"

#include <algorithm>
#include <cmath>
#include <string>

#include <Eigen/Eigenvalues>

namespace evermap::messages {

Expected<core::Mat6> covarianceFromMessage(const double* row_major, const char* what) {
  for (int i = 0; i < 36; ++i)
    if (!std::isfinite(row_major[i])) return Error(std::string(what) + ": covariance is not finite");
  core::Mat6 c;
  for (int r = 0; r < 6; ++r)
    for (int k = 0; k < 6; ++k) c(r, k) = row_major[6 * r + k];
  const double scale = std::max(1e-12, c.diagonal().cwiseAbs().maxCoeff());
  if ((c - c.transpose()).cwiseAbs().maxCoeff() > 1e-9 * scale)
    return Error(std::string(what) + ": covariance is not symmetric");
  const core::Mat6 symmetric = 0.5 * (c + c.transpose());
  Eigen::SelfAdjointEigenSolver<core::Mat6> eig(symmetric);
  if (eig.eigenvalues().minCoeff() < -1e-9 * scale)
    return Error(std::string(what) + ": covariance is not positive semi-definite");
  return symmetric;
}

}  // namespace evermap::messages
