#include "core/messages/odometry_frame.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>

#include "core/common/finite.h"
#include "core/messages/pose_fields.h"

namespace evermap::messages {
namespace {

// A pose from translation[3] and orientation[4] (w x y z); empty when not finite or not unit.
std::optional<core::SE3d> poseOf(const double* t, const double* q) {
  if (!allFinite(t, 3)) return std::nullopt;
  const Expected<Eigen::Quaterniond> rot = quaternionFromMessage(q, "VO_DELTA");
  if (!rot) return std::nullopt;
  return core::SE3d(rot->normalized(), core::Vec3(t[0], t[1], t[2]));
}

// Symmetric, negative eigenvalues (rounding) set to zero.
template <int N>
Eigen::Matrix<double, N, N> clippedToPsd(const Eigen::Matrix<double, N, N>& c) {
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, N, N>> eig(0.5 * (c + c.transpose()));
  const Eigen::Matrix<double, N, 1> lambda = eig.eigenvalues().cwiseMax(0.0);
  const Eigen::Matrix<double, N, N> out =
      eig.eigenvectors() * lambda.asDiagonal() * eig.eigenvectors().transpose();
  return 0.5 * (out + out.transpose());
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

Expected<core::UncertainPose> odometryBetween(const OdometryPose& a,
                                              const core::Mat6& a_own_covariance,
                                              const OdometryPose& b) {
  if (a.epoch != b.epoch) return makeError("odometry epochs differ (", a.epoch, ", ", b.epoch, ")");
  if (b.utime <= a.utime) return makeError("odometry pose at ", b.utime, " is not after ", a.utime);
  core::UncertainPose out;
  out.mean = a.odom_T_cam.mean.inverse() * b.odom_T_cam.mean;
  const core::Mat6 ad = out.mean.inverse().adjoint();  // Ad(b_T_a)
  const core::Mat6 rel = b.odom_T_cam.covariance - ad * a.odom_T_cam.covariance * ad.transpose() +
                         2.0 * ad * a_own_covariance * ad.transpose();
  out.covariance = clippedToPsd<6>(rel);
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

namespace {

// a ⊕ d with Σ = J1 Σ_a J1ᵀ + J2 Σ_d J2ᵀ.
WheelOdometryPose compound(const WheelOdometryPose& a, const PlanarMotion& d, int64_t utime) {
  Eigen::Matrix3d j1, j2;
  WheelOdometryPose b;
  b.epoch = a.epoch;
  b.utime = utime;
  b.odom_T_body = core::compose(a.odom_T_body, d.a_T_b, &j1, &j2);
  b.covariance =
      clippedToPsd<3>(j1 * a.covariance * j1.transpose() + j2 * d.covariance * j2.transpose());
  return b;
}

// The share f of a motion at constant rate (its twist scaled) and its variance scaled by f.
PlanarMotion share(const PlanarMotion& d, double f) {
  return PlanarMotion{core::SE2d::exp(f * d.a_T_b.log()), f * d.covariance};
}

}  // namespace

std::optional<WheelOdometryPose> wheelOdometryPose(const evermap::wheel_odom_t& m,
                                                   std::string* why) {
  const auto fail = [&](const char* what) -> std::optional<WheelOdometryPose> {
    if (why) *why = what;
    return std::nullopt;
  };
  if (m.odom_epoch == 0) return fail("no odometry pose");
  if (!std::isfinite(m.odom_x_m) || !std::isfinite(m.odom_y_m) || !std::isfinite(m.odom_theta_rad))
    return fail("odometry pose not finite");
  const auto c = planarCovarianceFromMessage(m.odom_covariance, "odometry pose");
  if (!c) return fail("odometry covariance not finite or not symmetric positive semi-definite");
  WheelOdometryPose p;
  p.epoch = m.odom_epoch;
  p.utime = m.utime;
  p.odom_T_body = core::SE2d(m.odom_x_m, m.odom_y_m, m.odom_theta_rad);
  p.covariance = *c;
  return p;
}

Expected<PlanarMotion> wheelOdometryBetween(const WheelOdometryPose& a,
                                            const WheelOdometryPose& b) {
  if (a.epoch != b.epoch)
    return makeError("wheel odometry epochs differ (", a.epoch, ", ", b.epoch, ")");
  if (b.utime < a.utime)
    return makeError("wheel odometry pose at ", b.utime, " is before ", a.utime);
  PlanarMotion d;
  d.a_T_b = core::between(a.odom_T_body, b.odom_T_body);
  Eigen::Matrix3d j1, j2;
  (void)core::compose(a.odom_T_body, d.a_T_b, &j1, &j2);
  const Eigen::Matrix3d j2_inv = j2.inverse();  // a rotation block and 1: always invertible
  d.covariance = clippedToPsd<3>(j2_inv * (b.covariance - j1 * a.covariance * j1.transpose()) *
                                 j2_inv.transpose());
  return d;
}

std::optional<WheelOdometryPose> wheelOdometryAt(const std::deque<WheelOdometryPose>& poses,
                                                 int64_t utime) {
  if (poses.empty() || utime < poses.front().utime) return std::nullopt;
  if (poses.size() == 1)
    return utime == poses.front().utime ? std::optional(poses.front()) : std::nullopt;
  auto b = std::lower_bound(poses.begin(), poses.end(), utime,
                            [](const WheelOdometryPose& p, int64_t t) { return p.utime < t; });
  if (b != poses.end() && b->utime == utime) return *b;
  const bool past_end = b == poses.end();
  if (past_end) --b;
  const WheelOdometryPose& a = *std::prev(b);
  if (a.epoch != b->epoch || b->utime <= a.utime) return std::nullopt;
  const auto d = wheelOdometryBetween(a, *b);
  if (!d) return std::nullopt;
  const double span = static_cast<double>(b->utime - a.utime);
  if (!past_end) return compound(a, share(*d, static_cast<double>(utime - a.utime) / span), utime);
  const double f = static_cast<double>(utime - b->utime) / span;
  if (f > 2.0) return std::nullopt;  // the wheels are silent: nothing to extrapolate from
  PlanarMotion ahead = share(*d, f);
  ahead.covariance *= 2.0;
  return compound(*b, ahead, utime);
}

void WheelOdometryFrame::stamp(evermap::wheel_odom_t& m) {
  PlanarMotion d;
  d.a_T_b = core::SE2d(m.delta_x_m, m.delta_y_m, m.delta_theta_rad);
  const auto c = planarCovarianceFromMessage(m.covariance, "WHEEL_ODOM");
  const bool valid = std::isfinite(m.delta_x_m) && std::isfinite(m.delta_y_m) &&
                     std::isfinite(m.delta_theta_rad) && c && m.prev_utime <= m.utime;
  if (!valid) {
    // An increment that is no motion: what follows starts again.
    pose_ = WheelOdometryPose{};
    m.odom_epoch = 0;
    m.odom_x_m = m.odom_y_m = m.odom_theta_rad = 0.0;
    for (double& v : m.odom_covariance) v = 0.0;
    return;
  }
  d.covariance = *c;
  if (pose_.epoch == 0 || m.prev_utime != pose_.utime) {
    // The first increment, or one that does not start where the last ended.
    pose_ = WheelOdometryPose{};
    pose_.epoch = m.prev_utime != 0 ? m.prev_utime : 1;  // 0 means "no pose"
    pose_.utime = m.prev_utime;
  }
  pose_ = compound(pose_, d, m.utime);
  m.odom_epoch = pose_.epoch;
  m.odom_x_m = pose_.odom_T_body.x();
  m.odom_y_m = pose_.odom_T_body.y();
  m.odom_theta_rad = pose_.odom_T_body.theta();
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 3; ++k) m.odom_covariance[3 * r + k] = pose_.covariance(r, k);
}

}  // namespace evermap::messages
