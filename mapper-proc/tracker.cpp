#include "mapper-proc/tracker.h"

#include <cmath>
#include <string>

#include <Eigen/Eigenvalues>

namespace evermap::mapper {
namespace {

bool finiteArray(const double* v, int n) {
  for (int i = 0; i < n; ++i)
    if (!std::isfinite(v[i])) return false;
  return true;
}

Mat6 symmetric(const Mat6& m) { return 0.5 * (m + m.transpose()); }

}  // namespace

Status TrackerOptions::validate() const {
  if (!(wheel_offplane_sigma_m > 0.0)) return Error("tracker.wheel_offplane_sigma_m: must be > 0");
  if (!(wheel_offplane_sigma_rad > 0.0)) return Error("tracker.wheel_offplane_sigma_rad: must be > 0");
  if (!(history_s > 0.0)) return Error("tracker.history_s: must be > 0");
  return Ok{};
}

Expected<Mat6> covarianceFromMessage(const double* row_major, const char* what) {
  if (!finiteArray(row_major, 36)) return Error(std::string(what) + ": covariance is not finite");
  Mat6 c;
  for (int r = 0; r < 6; ++r)
    for (int k = 0; k < 6; ++k) c(r, k) = row_major[6 * r + k];
  const double scale = std::max(1e-12, c.diagonal().cwiseAbs().maxCoeff());
  if ((c - c.transpose()).cwiseAbs().maxCoeff() > 1e-9 * scale)
    return Error(std::string(what) + ": covariance is not symmetric");
  Eigen::SelfAdjointEigenSolver<Mat6> eig(symmetric(c));
  if (eig.eigenvalues().minCoeff() < -1e-9 * scale)
    return Error(std::string(what) + ": covariance is not positive semi-definite");
  return symmetric(c);
}

Tracker::Tracker(const TrackerOptions& options)
    : o_(options), ad_body_T_cam_(options.body_T_cam.adjoint()) {}

UncertainPose Tracker::toBody(const SE3d& cam_motion, const Mat6& cam_covariance) const {
  // X' = A X A⁻¹ and X exp(δ) ↦ X' exp(Ad(A) δ) with A = body_T_cam.
  UncertainPose p;
  p.mean = o_.body_T_cam * cam_motion * o_.body_T_cam.inverse();
  p.covariance = symmetric(ad_body_T_cam_ * cam_covariance * ad_body_T_cam_.transpose());
  return p;
}

void Tracker::commit(int64_t utime, const UncertainPose& increment) {
  base_ = core::compound(base_, increment);  // eq. (6)-(7)
  history_.push_back(Increment{utime, increment});
  const int64_t window = static_cast<int64_t>(o_.history_s * 1e6);
  while (!history_.empty() && history_.front().utime < utime - window) history_.pop_front();
}

Status Tracker::addVo(const vo_delta_t& msg) {
  if (msg.utime <= last_vo_utime_) {
    ++counts_.dropped;
    return Error("VO_DELTA " + std::to_string(msg.utime) + ": out of order");
  }
  const bool restart = msg.keyframe_changed && msg.ref_utime == msg.utime;
  const bool failed = msg.status != vo_delta_t::STATUS_OK && !restart;
  // A frame's pose and covariance are checked before anything, its time stamp included, is
  // taken from it: a malformed message leaves the tracker as it was.
  Expected<Mat6> cov = Mat6::Zero().eval();
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  if (!failed && !restart) {
    if (!vo_mode_ || msg.ref_utime != ref_utime_) {
      ++counts_.dropped;
      return Error("VO_DELTA " + std::to_string(msg.utime) + ": unknown reference keyframe " +
                   std::to_string(msg.ref_utime));
    }
    if (!finiteArray(msg.translation, 3) || !finiteArray(msg.orientation, 4)) {
      ++counts_.dropped;
      return Error("VO_DELTA " + std::to_string(msg.utime) + ": pose is not finite");
    }
    q = Eigen::Quaterniond(msg.orientation[0], msg.orientation[1], msg.orientation[2], msg.orientation[3]);
    if (std::abs(q.norm() - 1.0) > 1e-3) {
      ++counts_.dropped;
      return Error("VO_DELTA " + std::to_string(msg.utime) + ": quaternion is not unit");
    }
    cov = covarianceFromMessage(msg.covariance, "VO_DELTA");
    if (!cov) {
      ++counts_.dropped;
      return makeError("VO_DELTA ", msg.utime, ": ", cov.error().message);
    }
  }
  last_vo_utime_ = msg.utime;
  last_utime_ = std::max(last_utime_, msg.utime);
  if (failed) {
    ++counts_.vo_failed;
    if (vo_mode_) {
      // The last good frame becomes the commit point wheel odometry continues from.
      commit(msg.utime, pending_);
      pending_ = UncertainPose{};
      vo_mode_ = false;
      vo_lost_utime_ = msg.utime;
    }
    return Ok{};
  }
  if (restart) {
    // A new reference keyframe at the current pose (VO restarted, or its first frame).
    if (vo_mode_) commit(msg.utime, pending_);
    else commit(msg.utime, UncertainPose{});
    pending_ = UncertainPose{};
    vo_mode_ = true;
    ref_utime_ = msg.utime;
    ++counts_.vo_applied;
    return Ok{};
  }
  pending_ = toBody(SE3d(q.normalized(), core::Vec3(msg.translation[0], msg.translation[1], msg.translation[2])),
                    *cov);
  ++counts_.vo_applied;
  if (msg.keyframe_changed) {
    commit(msg.utime, pending_);
    pending_ = UncertainPose{};
    ref_utime_ = msg.utime;
  }
  return Ok{};
}

Status Tracker::addWheel(const wheel_odom_t& msg) {
  if (msg.utime <= last_wheel_utime_ || msg.prev_utime > msg.utime) {
    ++counts_.dropped;
    return Error("WHEEL_ODOM " + std::to_string(msg.utime) + ": out of order");
  }
  if (!std::isfinite(msg.delta_x_m) || !std::isfinite(msg.delta_y_m) ||
      !std::isfinite(msg.delta_theta_rad) || !finiteArray(msg.covariance, 9)) {
    ++counts_.dropped;
    return Error("WHEEL_ODOM " + std::to_string(msg.utime) + ": not finite");
  }
  Eigen::Matrix3d c3;
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 3; ++k) c3(r, k) = msg.covariance[3 * r + k];
  const double scale = std::max(1e-12, c3.diagonal().cwiseAbs().maxCoeff());
  if ((c3 - c3.transpose()).cwiseAbs().maxCoeff() > 1e-9 * scale ||
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(0.5 * (c3 + c3.transpose())).eigenvalues().minCoeff() <
          -1e-9 * scale) {
    ++counts_.dropped;
    return Error("WHEEL_ODOM " + std::to_string(msg.utime) + ": covariance is not symmetric positive semi-definite");
  }
  last_wheel_utime_ = msg.utime;
  // Used only while VO is down, for the increments that end after VO was lost.
  if (vo_mode_ || msg.utime <= vo_lost_utime_) return Ok{};
  last_utime_ = std::max(last_utime_, msg.utime);
  UncertainPose inc;
  inc.mean = SE3d(core::SO3d::exp(core::Vec3(0, 0, msg.delta_theta_rad)),
                  core::Vec3(msg.delta_x_m, msg.delta_y_m, 0.0));
  // (x, y, θ) map to tangent entries (υx, υy, ωz) = 0, 1, 5; the planar SSC covariance equals
  // the right-perturbation one to first order for increments this small.
  const int idx[3] = {0, 1, 5};
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) inc.covariance(idx[r], idx[c]) = msg.covariance[3 * r + c];
  const double sm = o_.wheel_offplane_sigma_m, sr = o_.wheel_offplane_sigma_rad;
  inc.covariance(2, 2) += sm * sm;
  inc.covariance(3, 3) += sr * sr;
  inc.covariance(4, 4) += sr * sr;
  inc.covariance = symmetric(inc.covariance);
  commit(msg.utime, inc);
  ++counts_.wheel_applied;
  return Ok{};
}

UncertainPose Tracker::delta() const { return core::compound(base_, pending_); }

void Tracker::reset(const UncertainPose& active_T_body) {
  // Δ = base ⊕ pending must equal the new value; the pending VO offset stays (its keyframe
  // is still VO's reference), so the base absorbs its inverse. The pending covariance is
  // measured from the keyframe and is counted again from here: conservative.
  base_.mean = active_T_body.mean * pending_.mean.inverse();
  base_.covariance = active_T_body.covariance;
}

void Tracker::addHeight(double dz_m, double sigma_m) {
  // A vertical displacement in the world; the body is level to the IMU's accuracy, so it is
  // the same displacement in the body frame and commutes with the pending VO offset.
  UncertainPose lift;
  lift.mean = SE3d(core::SO3d(), core::Vec3(0, 0, dz_m));
  lift.covariance(2, 2) = sigma_m * sigma_m;
  base_ = core::compound(base_, lift);
}

std::optional<UncertainPose> Tracker::sinceKeyframe(int64_t keyframe_utime) const {
  // The commit point at the keyframe is the increment that ends there.
  auto it = history_.end();
  for (auto h = history_.rbegin(); h != history_.rend(); ++h) {
    if (h->utime == keyframe_utime) {
      it = h.base();  // the element after *h
      break;
    }
    if (h->utime < keyframe_utime) break;
  }
  if (it == history_.end() && (history_.empty() || history_.back().utime != keyframe_utime))
    return std::nullopt;
  UncertainPose out;
  for (; it != history_.end(); ++it) out = core::compound(out, it->pose);
  return core::compound(out, pending_);
}

}  // namespace evermap::mapper
