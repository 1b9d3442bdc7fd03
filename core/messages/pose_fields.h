#pragma once
// A pose into the translation[3] and orientation[4] (w, x, y, z) fields that pose-carrying
// messages have (pose_t, map_graph_t's nodes and edges), and a 6x6 covariance out of a
// row-major covariance[36] field (vo_delta_t, register_result_t), or a 3x3 one out of a
// covariance[9] field (wheel_odom_t).

#include "core/common/expected.h"
#include "core/geometry/se3.h"

namespace evermap::messages {

inline void putPose(const core::SE3d& pose, double* translation, double* orientation) {
  for (int k = 0; k < 3; ++k) translation[k] = pose.translation()[k];
  const Eigen::Quaterniond& q = pose.quaternion();
  orientation[0] = q.w();
  orientation[1] = q.x();
  orientation[2] = q.y();
  orientation[3] = q.z();
}

// Covariance from a row-major 6x6 message field, symmetrised; an error naming `what` when it
// is not finite or not symmetric positive semi-definite (within rounding).
Expected<core::Mat6> covarianceFromMessage(const double* row_major, const char* what);
// The same for a row-major 3x3 field over (x, y, θ) (wheel_odom_t).
Expected<Eigen::Matrix3d> planarCovarianceFromMessage(const double* row_major, const char* what);

}  // namespace evermap::messages
