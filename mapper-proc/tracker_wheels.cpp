// The tracker's wheel odometry (tracker.h): WHEEL_ODOM's increments taken in, kept while VO
// tracks to bridge its failures, compounded into Δ while VO is down, and their motion over a
// VO keyframe step fused into the step.
#include <algorithm>
#include <cmath>
#include <numbers>

#include "core/common/finite.h"
#include "core/messages/pose_fields.h"
#include "mapper-proc/tracker.h"

namespace evermap::mapper {
namespace {

Eigen::Vector3d wheelVector(const wheel_odom_t& w) {
  return Eigen::Vector3d(w.delta_x_m, w.delta_y_m, w.delta_theta_rad);
}

Eigen::Matrix3d wheelCovariance(const wheel_odom_t& w) {
  Eigen::Matrix3d p;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) p(r, c) = w.covariance[3 * r + c];
  return p;
}

// w's motion over [from, to] at its constant rate: a share of it or, from its end on, an
// extrapolation, whose variance is the increment's own scaled and as much again for the
// change of speed it cannot see.
wheel_odom_t spanOf(const wheel_odom_t& w, int64_t from, int64_t to) {
  const double f = static_cast<double>(to - from) / static_cast<double>(w.utime - w.prev_utime);
  wheel_odom_t s = w;
  s.prev_utime = from;
  s.utime = to;
  s.delta_x_m *= f;
  s.delta_y_m *= f;
  s.delta_theta_rad *= f;
  const double variance_scale = from >= w.utime ? 2.0 * f : f;
  for (double& c : s.covariance) c *= variance_scale;
  return s;
}

}  // namespace

bool Tracker::wheelsCover(int64_t from_utime, int64_t to_utime) const {
  // The first increment kept may straddle from_utime (kept from a VO restart or a rejoin on,
  // when the increments before were cleared): its share after from_utime counts.
  if (recent_wheel_.empty() || recent_wheel_.front().prev_utime > from_utime) return false;
  // ... and reach `to_utime` (wheels that stopped or lag more would leave Δ frozen at
  // from_utime).
  return reaches(recent_wheel_.back(), to_utime);
}

bool Tracker::reaches(const wheel_odom_t& w, int64_t utime) {
  return w.utime > w.prev_utime && utime - w.utime <= 2 * (w.utime - w.prev_utime);
}

Status Tracker::addWheel(const wheel_odom_t& received) {
  const wheel_odom_t msg = bridgeWheelHole(received);
  if (msg.utime <= lastWheelUtime() || msg.prev_utime > msg.utime) {
    ++counts_.dropped;
    return Error("WHEEL_ODOM " + std::to_string(msg.utime) + ": out of order");
  }
  if (!std::isfinite(msg.delta_x_m) || !std::isfinite(msg.delta_y_m) ||
      !std::isfinite(msg.delta_theta_rad) || !allFinite(msg.covariance, 9)) {
    ++counts_.dropped;
    return Error("WHEEL_ODOM " + std::to_string(msg.utime) + ": not finite");
  }
  if (const auto c = messages::planarCovarianceFromMessage(msg.covariance, "WHEEL_ODOM"); !c) {
    ++counts_.dropped;
    return makeError("WHEEL_ODOM ", msg.utime, ": ", c.error().message);
  }
  if (const std::string implausible =
          implausibleMotion(std::hypot(msg.delta_x_m, msg.delta_y_m), std::abs(msg.delta_theta_rad),
                            msg.prev_utime, msg.utime);
      !implausible.empty()) {
    ++counts_.dropped;
    ++counts_.implausible;
    return makeError("WHEEL_ODOM ", msg.utime, ": ", implausible);
  }
  // A held step waits no longer than heading_wait_s of message time.
  if (heldStepDue(msg.utime)) takeHeldStep();
  last_wheel_received_ = msg;
  wheel_odometer_m_ += std::hypot(msg.delta_x_m, msg.delta_y_m);
  keepWheelPose(msg);
  if (vo_mode_) {
    // Kept to bridge a VO failure from its last good frame on.
    recent_wheel_.push_back(msg);
    const int64_t window = static_cast<int64_t>(o_.wheel_buffer_s * 1e6);
    while (!recent_wheel_.empty() && recent_wheel_.front().utime < msg.utime - window)
      recent_wheel_.pop_front();
    // VO silent: vo-proc gone or its messages lost.
    if (last_vo_utime_ >= 0 &&
        msg.utime - last_vo_utime_ > static_cast<int64_t>(o_.vo_timeout_s * 1e6)) {
      ++counts_.vo_timeouts;
      // VO's messages may only be lost (a partition): its last frame's odometry pose can
      // span the silence when VO is back (rejoin).
      const auto at_last_frame = odometry_at_delta_;
      enterWheelMode(last_vo_utime_);
      odometry_at_vo_lost_ = at_last_frame;
    }
    return Ok{};
  }
  // Used only while VO is down, for the increments that end after VO was lost.
  if (msg.utime <= vo_lost_utime_) return Ok{};
  applyWheel(msg, vo_lost_utime_);
  return Ok{};
}

void Tracker::keepWheelPose(const wheel_odom_t& msg) {
  if (msg.odom_epoch == 0) return;
  auto pose = messages::wheelOdometryPose(msg);
  if (!pose) {
    ++counts_.odometry_refused;
    return;
  }
  if (!wheel_poses_.empty() && wheel_poses_.back().epoch != pose->epoch) wheel_poses_.clear();
  wheel_poses_.push_back(*pose);
  while (wheel_poses_.size() > 2 && wheel_poses_.front().utime < msg.utime - 1'000'000)
    wheel_poses_.pop_front();
}

UncertainPose Tracker::planarMotion(const Eigen::Vector3d& x,
                                    const Eigen::Matrix3d& covariance) const {
  UncertainPose inc;
  inc.mean = SE3d(core::SO3d::exp(core::Vec3(0, 0, x[2])), core::Vec3(x[0], x[1], 0.0));
  const int idx[3] = {0, 1, 5};
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) inc.covariance(idx[r], idx[c]) = covariance(r, c);
  const double sm = o_.wheel_offplane_sigma_m, sr = o_.wheel_offplane_sigma_rad;
  inc.covariance(2, 2) += sm * sm;
  inc.covariance(3, 3) += sr * sr;
  inc.covariance(4, 4) += sr * sr;
  inc.covariance = symmetric(inc.covariance);
  return inc;
}

void Tracker::extrapolateWheel(int64_t utime) {
  // Wheels silent for more than two of their periods: nothing to extrapolate from.
  if (!last_wheel_ || utime <= last_wheel_->utime || !reaches(*last_wheel_, utime)) return;
  const wheel_odom_t x = spanOf(*last_wheel_, last_wheel_->utime, utime);
  applyWheel(x, x.prev_utime);
}

void Tracker::applyWheel(const wheel_odom_t& msg, int64_t from_utime) {
  odometry_at_delta_.reset();  // Δ moves past the last VO frame
  last_utime_ = std::max(last_utime_, msg.utime);
  last_wheel_ = msg;
  // An increment that starts before from_utime (VO's last good frame: VO covered that part):
  // only its share after it, at constant rate.
  const int64_t start = std::max(msg.prev_utime, from_utime);
  const wheel_odom_t share =
      start > msg.prev_utime && msg.utime > msg.prev_utime ? spanOf(msg, start, msg.utime) : msg;
  Eigen::Vector3d x = wheelVector(share);
  Eigen::Matrix3d P = wheelCovariance(share);
  const auto gyro = o_.gyro_heading ? gyroYaw(start, msg.utime) : std::nullopt;
  if (gyro && P(2, 2) + gyro->second > 0.0) {
    // The gyro's yaw as a measurement of θ (H = e_θ): a Kalman update of (x, y, θ), so a
    // correlation between the wheels' θ and their translation carries the correction over.
    const double innovation = std::remainder(gyro->first - x[2], 2.0 * std::numbers::pi);
    const Eigen::Vector3d k = P.col(2) / (P(2, 2) + gyro->second);
    x += k * innovation;
    P -= k * P.row(2);
    ++counts_.gyro_turns;
  }
  // The planar SSC covariance equals the right-perturbation one to first order for increments
  // this small.
  commit(msg.utime, planarMotion(x, P));
  delta_utime_ = msg.utime;
  ++counts_.wheel_applied;
}

std::optional<UncertainPose> Tracker::wheelMotion(int64_t t0, int64_t t1) const {
  if (t1 <= t0 || !wheelsCover(t0, t1)) return std::nullopt;
  UncertainPose out;
  std::optional<int64_t> previous_end;
  for (const wheel_odom_t& w : recent_wheel_) {
    // A hole between two increments (messages lost and not bridged) or an overlap: the
    // wheels' motion over the step is not known.
    const bool chained = !previous_end || w.prev_utime == *previous_end;
    previous_end = w.utime;
    if (w.utime <= t0 || w.prev_utime >= t1) continue;
    if (!chained || w.utime <= w.prev_utime) return std::nullopt;
    // The share of the increment inside [t0, t1].
    const wheel_odom_t s = spanOf(w, std::max(w.prev_utime, t0), std::min(w.utime, t1));
    out = core::compound(out, planarMotion(wheelVector(s), wheelCovariance(s)));
  }
  const wheel_odom_t& last = recent_wheel_.back();
  if (last.utime < t1) {
    // Past the last increment, extrapolated at its rate.
    const wheel_odom_t s = spanOf(last, std::max(last.utime, t0), t1);
    out = core::compound(out, planarMotion(wheelVector(s), wheelCovariance(s)));
  }
  return out;
}

UncertainPose Tracker::withWheelTranslation(int64_t t0, int64_t t1, const UncertainPose& vo) {
  if (!o_.wheel_translation) return vo;
  const auto wheels = wheelMotion(t0, t1);
  if (!wheels) return vo;
  // An EKF update on VO's right tangent (υ, ω): the wheels measure the translation in the
  // plane of the step's reference, t + R υ to first order, so H = [R's x-y rows, 0]. Their
  // translation's covariance in that frame is R_w Σ_υυ R_wᵀ.
  const Eigen::Matrix3d r = vo.mean.so3().matrix();
  Eigen::Matrix<double, 2, 6> h = Eigen::Matrix<double, 2, 6>::Zero();
  h.leftCols<3>() = r.topRows<2>();
  const Eigen::Matrix<double, 2, 3> rw = wheels->mean.so3().matrix().topRows<2>();
  const Eigen::Matrix2d measured = rw * wheels->covariance.topLeftCorner<3, 3>() * rw.transpose();
  const Eigen::Vector2d innovation =
      wheels->mean.translation().head<2>() - vo.mean.translation().head<2>();
  const Eigen::Matrix2d s = h * vo.covariance * h.transpose() + measured;
  const Eigen::LDLT<Eigen::Matrix2d> s_ldlt(s);
  if (s_ldlt.info() != Eigen::Success || !(s_ldlt.vectorD().minCoeff() > 0.0)) return vo;
  const Eigen::Matrix<double, 6, 2> k = s_ldlt.solve(h * vo.covariance).transpose();
  // The Joseph form: positive semi-definite also when VO's covariance is far larger than the
  // wheels' (the corridor). The covariance stays on the tangent at VO's mean (first order, as
  // withGyroYaw).
  const Mat6 i_kh = Mat6::Identity() - k * h;
  UncertainPose out;
  out.mean = vo.mean * SE3d::exp(k * innovation);
  out.covariance =
      symmetric(i_kh * vo.covariance * i_kh.transpose() + k * measured * k.transpose());
  ++counts_.wheel_fused;
  // Beyond χ²(2) 99.9 %: counted (a fault one of the two covariances did not know).
  if (innovation.dot(s_ldlt.solve(innovation)) > 13.82) ++counts_.wheel_disagreed;
  return out;
}

}  // namespace evermap::mapper
