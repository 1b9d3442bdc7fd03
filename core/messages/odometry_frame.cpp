#include "core/messages/odometry_frame.h"

#include <cmath>

#include <Eigen/Eigenvalues>

#include "core/messages/pose_fields.h"

namespace evermap::messages {
namespace {

bool finite(const double* v, int n) {
  for (int i = 0; i < n; ++i)
    if (!std::isfinite(v[i])) return false;
  return true;
}

// A pose from translation[3] and orientation[4] (w x y z); empty when not finite or not unit.
std::optional<core::SE3d> poseOf(const double* t, const double* q) {
  if (!finite(t, 3) || !finite(q, 4)) return std::nullopt;
  const Eigen::Quaterniond rot(q[0], q[1], q[2], q[3]);
  if (std::abs(rot.norm() - 1.0) > 1e-3) return std::nullopt;
  return core::SE3d(rot.normalized(), core::Vec3(t[0], t[1], t[2]));
}

}  // namespace

std::optional<OdometryPose> odometryPose(const evermap::vo_delta_t& m, std::string* why) {
  const auto fail = [&](const char* what) -> std::optional<OdometryPose> {
    if (why) *why = what;
    return std::nullopt;
  };
  if (m.odom_epoch == 0) return fail("no odometry pose");
  const auto pose = poseOf(m.odom_translation, m.odom_orientation);
  if (!pose) return fail("odometry pose not finite or its quaternion not unit");
  const auto c = covarianceFromMessage(m.odom_covariance, "odometry pose");
  if (!c) return fail("odometry covariance not symmetric positive semi-definite");
  OdometryPose p;
  p.epoch = m.odom_epoch;
  p.utime = m.utime;
  p.odom_T_cam = core::UncertainPose{*pose, *c};
  return p;
}

Expected<core::UncertainPose> odometryBetween(const OdometryPose& a, const core::Mat6& a_own_covariance,
                                              const OdometryPose& b) {
  if (a.epoch != b.epoch) return makeError("odometry epochs differ (", a.epoch, ", ", b.epoch, ")");
  if (b.utime <= a.utime) return makeError("odometry pose at ", b.utime, " is not after ", a.utime);
  core::UncertainPose out;
  out.mean = a.odom_T_cam.mean.inverse() * b.odom_T_cam.mean;
  const core::Mat6 ad = out.mean.inverse().adjoint();  // Ad(b_T_a)
  const core::Mat6 rel = b.odom_T_cam.covariance - ad * a.odom_T_cam.covariance * ad.transpose() +
                         2.0 * ad * a_own_covariance * ad.transpose();
  Eigen::SelfAdjointEigenSolver<core::Mat6> eig(0.5 * (rel + rel.transpose()));
  const core::Vec6 lambda = eig.eigenvalues().cwiseMax(0.0);
  out.covariance = eig.eigenvectors() * lambda.asDiagonal() * eig.eigenvectors().transpose();
  out.covariance = 0.5 * (out.covariance + out.covariance.transpose()).eval();
  return out;
}

void OdometryFrame::startEpoch(int64_t utime) {
  epoch_ = utime != 0 ? utime : 1;  // 0 means "no pose"; a stream that starts at time 0

  ref_utime_ = utime;
  odom_T_ref_ = core::UncertainPose{};
}

void OdometryFrame::stamp(evermap::vo_delta_t& m) {
  const bool ok = m.status == evermap::vo_delta_t::STATUS_OK;
  std::optional<core::UncertainPose> odom_T_cur;
  if (m.keyframe_changed && (!ok || m.ref_utime == m.utime)) {
    // The contract's chain restart: this frame is the new reference, its motion unknown.
    startEpoch(m.utime);
    odom_T_cur = odom_T_ref_;
  } else if (ok) {
    const auto ref_T_cur = poseOf(m.translation, m.orientation);
    const auto c = covarianceFromMessage(m.covariance, "VO_DELTA");
    if (epoch_ != 0 && m.ref_utime == ref_utime_ && ref_T_cur && c) {
      odom_T_cur = core::compound(odom_T_ref_, core::UncertainPose{*ref_T_cur, *c});
      if (m.keyframe_changed) {
        odom_T_ref_ = *odom_T_cur;
        ref_utime_ = m.utime;
      }
    } else if (m.keyframe_changed) {
      // A reference this frame never saw: the chain starts again here.
      startEpoch(m.utime);
      odom_T_cur = odom_T_ref_;
    } else {
      epoch_ = 0;  // unknown until the next keyframe starts an epoch
    }
  }
  if (!odom_T_cur) {
    m.odom_epoch = 0;
    putPose(core::SE3d(), m.odom_translation, m.odom_orientation);
    for (double& v : m.odom_covariance) v = 0.0;
    return;
  }
  m.odom_epoch = epoch_;
  putPose(odom_T_cur->mean, m.odom_translation, m.odom_orientation);
  for (int r = 0; r < 6; ++r)
    for (int k = 0; k < 6; ++k) m.odom_covariance[6 * r + k] = odom_T_cur->covariance(r, k);
}

}  // namespace evermap::messages
