#pragma once
// A pose into, and out of, the translation[3] and orientation[4] (w, x, y, z) fields that
// pose-carrying messages have (pose_t, vo_delta_t, register_result_t, map_graph_t's nodes and
// edges), and a 6x6 covariance out of a
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

// The rotation an orientation[4] field (w, x, y, z) holds, as read: the caller's SO3d / SE3d
// normalises it. An error naming `what` when a component is not finite or the norm is farther
// than kUnitQuaternionTolerance from 1.
inline constexpr double kUnitQuaternionTolerance = 1e-3;
Expected<Eigen::Quaterniond> quaternionFromMessage(const double* orientation, const char* what);
// The pose of translation[3] and orientation[4] fields (putPose's inverse): the translation
// finite, the quaternion checked as above.
Expected<core::SE3d> poseFromMessage(const double* translation, const double* orientation,
                                     const char* what);

// Covariance from a row-major 6x6 message field, symmetrised; an error naming `what` when it
// is not finite or not symmetric positive semi-definite (within rounding).
Expected<core::Mat6> covarianceFromMessage(const double* row_major, const char* what);
// The same for a row-major 3x3 field over (x, y, θ) (wheel_odom_t).
Expected<Eigen::Matrix3d> planarCovarianceFromMessage(const double* row_major, const char* what);

}  // namespace evermap::messages
