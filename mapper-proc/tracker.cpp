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
  if (!(vo_timeout_s > 0.0)) return Error("tracker.vo_timeout_s: must be > 0");
  if (!(relink_gate > 0.0)) return Error("tracker.relink_gate: must be > 0");
  if (!(wheel_buffer_s >= 0.0)) return Error("tracker.wheel_buffer_s: must be >= 0");
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

// Whether two estimates of one motion agree in the plane (x, y, yaw of the right tangent):
// χ²(3) of their difference under the sum of their covariances.
static bool agreesInPlane(const UncertainPose& a, const UncertainPose& b, double gate) {
  const core::Vec6 d = (a.mean.inverse() * b.mean).log();
  const int idx[3] = {0, 1, 5};
  Eigen::Vector3d r;
  Eigen::Matrix3d c;
  for (int i = 0; i < 3; ++i) {
    r[i] = d[idx[i]];
    for (int j = 0; j < 3; ++j) c(i, j) = a.covariance(idx[i], idx[j]) + b.covariance(idx[i], idx[j]);
  }
  c += Eigen::Matrix3d::Identity() * 1e-12;
  return r.dot(c.ldlt().solve(r)) <= gate;
}

Tracker::Tracker(const TrackerOptions& options)
    : o_(options), ad_body_T_cam_(options.body_T_cam.adjoint()) {}

void Tracker::setBodyTCamera(const SE3d& body_T_cam) {
  o_.body_T_cam = body_T_cam;
  ad_body_T_cam_ = body_T_cam.adjoint();
}

UncertainPose Tracker::toBody(const SE3d& cam_motion, const Mat6& cam_covariance) const {
  // X' = A X A⁻¹ and X exp(δ) ↦ X' exp(Ad(A) δ) with A = body_T_cam.
  UncertainPose p;
  p.mean = o_.body_T_cam * cam_motion * o_.body_T_cam.inverse();
  p.covariance = symmetric(ad_body_T_cam_ * cam_covariance * ad_body_T_cam_.transpose());
  return p;
}

void Tracker::commit(int64_t utime, const UncertainPose& increment) {
  base_ = core::compound(base_, increment);  // eq. (6)-(7)
  path_odometer_m_ += increment.mean.translation().norm();
  history_.push_back(Increment{utime, increment});
  const int64_t window = static_cast<int64_t>(o_.history_s * 1e6);
  while (!history_.empty() && history_.front().utime < utime - window) history_.pop_front();
}

Status Tracker::addVo(const vo_delta_t& msg) {
  if (msg.utime <= last_vo_utime_) {
    ++counts_.dropped;
    return Error("VO_DELTA " + std::to_string(msg.utime) + ": out of order");
  }
  const bool ok = msg.status == vo_delta_t::STATUS_OK;
  // A new reference without a motion to it: VO's first frame, or a chain break.
  const bool restart = msg.keyframe_changed && (!ok || msg.ref_utime == msg.utime);
  // A frame's pose and covariance are checked before anything, its time stamp included, is
  // taken from it: a malformed message leaves the tracker as it was.
  Expected<Mat6> cov = Mat6::Zero().eval();
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  if (ok && !restart) {
    if (msg.ref_utime >= msg.utime) {
      ++counts_.dropped;
      return Error("VO_DELTA " + std::to_string(msg.utime) + ": reference " +
                   std::to_string(msg.ref_utime) + " is not before the frame");
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
  const int64_t previous_vo_utime = last_vo_utime_;
  last_vo_utime_ = msg.utime;
  last_utime_ = std::max(last_utime_, msg.utime);
  if (restart) {
    // A new reference keyframe at the current estimate.
    if (vo_mode_) commit(msg.utime, pending_);
    else commit(msg.utime, UncertainPose{});
    pending_ = UncertainPose{};
    vo_mode_ = true;
    ref_utime_ = msg.utime;
    recent_wheel_.clear();
    ++counts_.restarts;
    if (ok) ++counts_.vo_applied;
    else ++counts_.vo_failed;
    return Ok{};
  }
  if (!ok) {
    ++counts_.vo_failed;
    // The last good frame becomes the commit point wheel odometry continues from.
    if (vo_mode_) enterWheelMode(previous_vo_utime);
    return Ok{};
  }
  const UncertainPose ref_T_body =
      toBody(SE3d(q.normalized(), core::Vec3(msg.translation[0], msg.translation[1], msg.translation[2])), *cov);
  if (!vo_mode_ || msg.ref_utime != ref_utime_) rejoin(msg.ref_utime, ref_T_body, msg.utime);
  pending_ = ref_T_body;
  ++counts_.vo_applied;
  if (msg.keyframe_changed) {
    commit(msg.utime, pending_);
    pending_ = UncertainPose{};
    ref_utime_ = msg.utime;
  }
  return Ok{};
}

void Tracker::enterWheelMode(int64_t lost_utime) {
  commit(std::max(lost_utime, history_.empty() ? lost_utime : history_.back().utime), pending_);
  pending_ = UncertainPose{};
  vo_mode_ = false;
  vo_lost_utime_ = lost_utime;
  std::deque<wheel_odom_t> buffered;
  buffered.swap(recent_wheel_);
  for (const wheel_odom_t& w : buffered)
    if (w.utime > lost_utime) applyWheel(w);
}

void Tracker::rejoin(int64_t ref_utime, const UncertainPose& ref_T_body, int64_t utime) {
  if (vo_mode_) {
    // VO moved on to a reference whose keyframe change never arrived: commit what is known.
    commit(utime, pending_);
    pending_ = UncertainPose{};
  }
  // Back on the reference VO kept through its failures: the reference's commit point is in
  // the history; the increments after it (wheel odometry) are taken back, VO replaces them.
  // The covariance keeps them: conservative.
  if (!vo_mode_ && ref_utime == ref_utime_) {
    auto at = history_.end();
    for (auto h = history_.begin(); h != history_.end(); ++h)
      if (h->utime == ref_utime) at = h;
    UncertainPose wheel;  // what wheel odometry says of the same motion
    if (at != history_.end())
      for (auto h = std::next(at); h != history_.end(); ++h) wheel = core::compound(wheel, h->pose);
    if (at != history_.end() && !agreesInPlane(wheel, ref_T_body, o_.relink_gate)) {
      // VO's motion over the gap contradicts the wheels: a wrong registration (a repeated
      // texture); the frame goes where the wheels put it instead.
      ++counts_.relinks_refused;
      at = history_.end();
    }
    if (at != history_.end()) {
      SE3d undo;
      for (auto h = std::next(at); h != history_.end(); ++h) undo = undo * h->pose.mean;
      base_.mean = base_.mean * undo.inverse();
      history_.erase(std::next(at), history_.end());
      vo_mode_ = true;
      recent_wheel_.clear();
      ++counts_.relinked;
      return;
    }
  }
  // An unknown reference: the frame goes where the estimate (wheel odometry) has the body, so
  // the reference sits at Δ ⊕ (ref_T_body)⁻¹; the increment to it is committed so that the
  // motion since an earlier keyframe still compounds to Δ.
  commit(utime, UncertainPose{ref_T_body.mean.inverse(), Mat6::Zero()});
  vo_mode_ = true;
  ref_utime_ = ref_utime;
  recent_wheel_.clear();
  ++counts_.reanchored;
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
  wheel_odometer_m_ += std::hypot(msg.delta_x_m, msg.delta_y_m);
  if (vo_mode_) {
    // Kept to bridge a VO failure from its last good frame on.
    recent_wheel_.push_back(msg);
    const int64_t window = static_cast<int64_t>(o_.wheel_buffer_s * 1e6);
    while (!recent_wheel_.empty() && recent_wheel_.front().utime < msg.utime - window) recent_wheel_.pop_front();
    // VO silent: vo-proc gone or its messages lost.
    if (last_vo_utime_ >= 0 && msg.utime - last_vo_utime_ > static_cast<int64_t>(o_.vo_timeout_s * 1e6)) {
      ++counts_.vo_timeouts;
      enterWheelMode(last_vo_utime_);
    }
    return Ok{};
  }
  // Used only while VO is down, for the increments that end after VO was lost.
  if (msg.utime <= vo_lost_utime_) return Ok{};
  applyWheel(msg);
  return Ok{};
}

void Tracker::applyWheel(const wheel_odom_t& msg) {
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
