#include "imu-proc/attitude_filter.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace evermap::imu {

namespace {

constexpr int kN = AttitudeFilter::kStateSize;
using MatN = Eigen::Matrix<double, kN, kN>;
using VecN = Eigen::Matrix<double, kN, 1>;
// Blocks of the error state.
constexpr int kTilt = 0, kBias = 2, kVel = 5;

// [e_z]x restricted to (dphi_x, dphi_y): [e_z]x dphi = (-dphi_y, dphi_x, 0).
Eigen::Matrix<double, 3, 2> ezCrossXY() {
  Eigen::Matrix<double, 3, 2> m;
  m << 0, -1, 1, 0, 0, 0;
  return m;
}

}  // namespace

// Single-field ranges are declared (attitude_filter.h); these are the rules between fields.
Status AttitudeFilterOptions::validate() const {
  if (Status s = checkOptionRanges(*this); !s) return s;
  if (!(max_tilt_sigma_rad >= initial_tilt_sigma_rad)) {
    return makeError("max_tilt_sigma_rad must be >= initial_tilt_sigma_rad");
  }
  return gate.validate();
}

std::string AttitudeFilterCounts::summary() const {
  char buf[260];
  std::snprintf(
      buf, sizeof buf,
      "%s; updates %lld, untrusted %lld, innovation rejected %lld, resets %lld, recoveries %lld, "
      "velocity resets %lld",
      accel_only ? "mode accelerometer only (no gyroscope)" : "mode gyroscope + accelerometer",
      static_cast<long long>(updates), static_cast<long long>(untrusted),
      static_cast<long long>(innovation_rejected), static_cast<long long>(resets),
      static_cast<long long>(recoveries), static_cast<long long>(velocity_resets));
  return buf;
}

AttitudeFilter::AttitudeFilter(const AttitudeFilterOptions& options)
    : options_(options), gate_(options.gate) {
  const Status st = options_.validate();
  if (!st.ok()) {
    std::fprintf(stderr, "evermap::imu::AttitudeFilter: %s\n", st.error().message.c_str());
    std::abort();  // broken contract: options are validated where they are read
  }
}

void AttitudeFilter::initialize(const ImuSample& s) {
  const Eigen::Vector2d rp = rollPitchFromUp(s.accel_m_s2);
  world_R_body_ = core::SO3d::fromRollPitchYaw(rp[0], rp[1], 0.0);
  smoothed_accel_ = s.accel_m_s2;
  last_gyro_ = s.gyro_rad_s;
  prev_gyro_ = s.gyro_rad_s;
  smoothed_horizontal_.setZero();
  untrusted_for_s_ = 0;
  rejected_for_s_ = 0;
  steady_but_rejected_ = false;
  // The first sample may be taken in motion: then its tilt is only known to max_tilt_sigma.
  const bool plausible =
      std::abs(s.accel_m_s2.norm() - options_.gravity_m_s2) <= options_.untrusted_accel_error_m_s2;
  const double tilt_var =
      std::pow(plausible ? options_.initial_tilt_sigma_rad : options_.max_tilt_sigma_rad, 2);
  const Eigen::Matrix3d P_bias =
      initialized_
          ? Eigen::Matrix3d(P_.block<3, 3>(kBias, kBias))
          : std::pow(options_.initial_gyro_bias_sigma_rad_s, 2) * Eigen::Matrix3d::Identity();
  P_.setZero();
  P_.block<2, 2>(kTilt, kTilt) = tilt_var * Eigen::Matrix2d::Identity();
  P_.block<3, 3>(kBias, kBias) = counts_.accel_only ? Eigen::Matrix3d::Zero() : P_bias;
  // Whatever the body does, it moves at about walking speed at most (the velocity prior).
  velocity_.setZero();
  P_.block<2, 2>(kVel, kVel) =
      std::pow(options_.velocity_prior_sigma_m_s, 2) * Eigen::Matrix2d::Identity();
  since_velocity_prior_s_ = 0;
  initialized_ = true;
  last_trusted_ = plausible;
}

void AttitudeFilter::finishStartup() {
  // Means over the two halves of the window: a body that holds still (vibration allowed:
  // rotors, a running engine) has the same mean rate and the same gravity direction in both.
  const size_t n = startup_.size(), half = n / 2;
  Eigen::Vector3d f[2] = {Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
  Eigen::Vector3d w[2] = {Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
  for (size_t i = 0; i < n; ++i) {
    const int h = i < half ? 0 : 1;
    f[h] += startup_[i].accel_m_s2;
    w[h] += startup_[i].gyro_rad_s;
  }
  bool gyro_all_zero = true;
  for (const ImuSample& s : startup_) gyro_all_zero = gyro_all_zero && s.gyro_rad_s.isZero(0.0);
  counts_.accel_only =
      options_.gyroscope_mode == 0 || (options_.gyroscope_mode < 0 && gyro_all_zero);
  ImuSample mean = startup_.back();
  mean.accel_m_s2 = (f[0] + f[1]) / static_cast<double>(n);
  initialize(mean);
  if (half >= 1) {
    for (int h = 0; h < 2; ++h) {
      const double m = static_cast<double>(h == 0 ? half : n - half);
      f[h] /= m;
      w[h] /= m;
    }
    const double rate_change = (w[1] - w[0]).norm();
    const double tilt_change =
        std::acos(std::clamp(f[0].normalized().dot(f[1].normalized()), -1.0, 1.0));
    counts_.still_start = rate_change <= options_.still_gyro_spread_rad_s &&
                          tilt_change <= options_.still_tilt_change_rad;
  }
  if (counts_.accel_only) {
    // No gyroscope: no bias to estimate, and none coupled into the tilt.
    bias_.setZero();
    P_.block<3, kN>(kBias, 0).setZero();
    P_.block<kN, 3>(0, kBias).setZero();
  } else if (counts_.still_start) {
    bias_ = 0.5 * (w[0] + w[1]);
    // The two half means differ by about sqrt(2) times the error of their average's
    // components; floor it at the random walk over the window.
    const double sigma = std::max((w[1] - w[0]).norm() / std::sqrt(6.0), 1e-4);
    P_.block<3, 3>(kBias, kBias) = sigma * sigma * Eigen::Matrix3d::Identity();
  }
  startup_.clear();
  startup_.shrink_to_fit();
}

bool AttitudeFilter::add(const ImuSample& s) {
  double dt = 0;
  const GateVerdict verdict = gate_.check(s, &dt);
  if (verdict == GateVerdict::kDrop) return false;
  utime_ = s.utime;
  if (!initialized_) {
    // Start-up: collect the window (a gap inside it starts the window again).
    if (verdict == GateVerdict::kAcceptAfterGap) startup_.clear();
    startup_.push_back(s);
    if (1e-6 * static_cast<double>(s.utime - startup_.front().utime) < options_.init_window_s) {
      return false;
    }
    finishStartup();
    return true;
  }
  if (verdict == GateVerdict::kAcceptAfterGap) {
    // Nothing is known about the rotation across a gap: start the tilt again from gravity.
    if (initialized_) ++counts_.resets;
    initialize(s);
    return true;
  }
  propagate(s, dt);
  if (options_.velocity_prior_sigma_m_s > 0) {
    since_velocity_prior_s_ += dt;
    if (since_velocity_prior_s_ >= options_.velocity_prior_period_s) {
      since_velocity_prior_s_ = 0;
      applyVelocityPrior();
    }
  }
  const bool trusted = accelTrusted(s.accel_m_s2, dt);
  if (steady_but_rejected_) {
    ++counts_.recoveries;
    ImuSample level = s;
    level.accel_m_s2 = smoothed_accel_;
    initialize(level);
    return true;
  }
  if (trusted) {
    last_trusted_ = true;
    // Per-sample variance of white noise with density q sampled every dt: q^2 / dt.
    const double var_dir = options_.linear_accel_density * options_.linear_accel_density / dt /
                           (options_.gravity_m_s2 * options_.gravity_m_s2);
    const Eigen::Matrix3d Rt = world_R_body_.matrix().transpose();
    Eigen::Matrix<double, 3, kN> H = Eigen::Matrix<double, 3, kN>::Zero();
    H.block<3, 2>(0, kTilt) = Rt * ezCrossXY();
    const Eigen::Vector3d r = s.accel_m_s2.normalized() - Rt.col(2);
    if (update<3>(r, H, var_dir * Eigen::Matrix3d::Identity())) {
      ++counts_.updates;
      rejected_for_s_ = 0;
    } else {
      ++counts_.innovation_rejected;
      last_trusted_ = false;
      rejected_for_s_ += dt;
      if (rejected_for_s_ > options_.max_rejected_s) {
        // Gravity has looked steady for seconds and disagrees with the estimate.
        ++counts_.recoveries;
        rejected_for_s_ = 0;
        ImuSample level = s;
        level.accel_m_s2 = smoothed_accel_;
        initialize(level);
      }
    }
  } else {
    last_trusted_ = false;
    ++counts_.untrusted;
  }
  return true;
}

template <int M>
bool AttitudeFilter::update(const Eigen::Matrix<double, M, 1>& r,
                            const Eigen::Matrix<double, M, kStateSize>& H,
                            const Eigen::Matrix<double, M, M>& R) {
  const Eigen::Matrix<double, M, M> S = H * P_ * H.transpose() + R;
  const Eigen::Matrix<double, M, M> S_inv = S.inverse();
  if (r.dot(S_inv * r) > options_.innovation_gate_chi2) return false;
  const Eigen::Matrix<double, kN, M> K = P_ * H.transpose() * S_inv;
  const VecN dx = K * r;
  // Joseph form keeps P symmetric positive definite over millions of updates.
  const MatN IKH = MatN::Identity() - K * H;
  P_ = IKH * P_ * IKH.transpose() + K * R * K.transpose();
  world_R_body_ = core::SO3d::exp(Eigen::Vector3d(dx[kTilt], dx[kTilt + 1], 0.0)) * world_R_body_;
  bias_ += dx.segment<3>(kBias);
  velocity_ += dx.segment<2>(kVel);
  return true;
}

void AttitudeFilter::applyVelocityPrior() {
  // z = 0 = v + n, n ~ N(0, sigma_v^2): the horizontal velocity is bounded. Successive
  // applications are velocity_prior_period_s apart, about the velocity's correlation time.
  Eigen::Matrix<double, 2, kN> H = Eigen::Matrix<double, 2, kN>::Zero();
  H.block<2, 2>(0, kVel).setIdentity();
  const Eigen::Matrix2d R =
      std::pow(options_.velocity_prior_sigma_m_s, 2) * Eigen::Matrix2d::Identity();
  if (!update<2>(-velocity_, H, R)) {
    // The integrated velocity went far off (a missed shock, a long free fall): start it again.
    ++counts_.velocity_resets;
    velocity_.setZero();
    P_.block<2, kN>(kVel, 0).setZero();
    P_.block<kN, 2>(0, kVel).setZero();
    P_.block<2, 2>(kVel, kVel) = R;
  }
}

void AttitudeFilter::propagate(const ImuSample& s, double dt) {
  if (counts_.accel_only) {
    // Tilt as a random walk; the bias block stays 0 (F = I, no noise there).
    MatN Q = MatN::Zero();
    Q.block<2, 2>(kTilt, kTilt) = options_.accel_only_tilt_rate_density *
                                  options_.accel_only_tilt_rate_density * dt *
                                  Eigen::Matrix2d::Identity();
    if (options_.velocity_prior_sigma_m_s > 0) {
      const Eigen::Vector3d f_world = world_R_body_ * s.accel_m_s2;
      velocity_ += f_world.head<2>() * dt;
      Q.block<2, 2>(kVel, kVel) = options_.accel_noise_density * options_.accel_noise_density * dt *
                                  Eigen::Matrix2d::Identity();
    }
    P_ += Q;
    capTiltVariance();
    return;
  }
  // Trapezoidal rate over the interval. Its error is about |w''| dt^3 / 12, with w'' from
  // the second difference of the readings: negligible at 200 Hz, a degree per step for a
  // phone swung at 10 Hz, where it widens the covariance so gravity takes over afterwards.
  const Eigen::Vector3d w = 0.5 * (s.gyro_rad_s + last_gyro_) - bias_;
  const double interp_err = (s.gyro_rad_s - 2.0 * last_gyro_ + prev_gyro_).norm() * dt / 12.0 *
                            options_.interpolation_error_scale;
  prev_gyro_ = last_gyro_;
  last_gyro_ = s.gyro_rad_s;
  world_R_body_ = world_R_body_ * core::SO3d::exp(w * dt);
  const Eigen::Matrix3d R = world_R_body_.matrix();
  // Horizontal specific force in the world = horizontal acceleration (gravity is vertical).
  const bool use_velocity = options_.velocity_prior_sigma_m_s > 0;
  MatN F = MatN::Identity();
  F.block<2, 3>(kTilt, kBias) = -R.topRows<2>() * dt;
  if (use_velocity) {
    const Eigen::Vector3d f_world = R * s.accel_m_s2;
    velocity_ += f_world.head<2>() * dt;
    // d(R f)/d(dphi) = -[R f]x; only the tilt columns couple (yaw error is not a state).
    Eigen::Matrix<double, 3, 2> ez_xy;
    ez_xy << 1, 0, 0, 1, 0, 0;
    F.block<2, 2>(kVel, kTilt) = (-core::hat(f_world) * ez_xy).topRows<2>() * dt;
  }
  MatN Q = MatN::Zero();
  // R n R^T with isotropic n is isotropic: the tilt noise does not depend on the attitude.
  const double scale_err = options_.gyro_scale_sigma * w.norm() * dt;
  Q.block<2, 2>(kTilt, kTilt) = (options_.gyro_noise_density * options_.gyro_noise_density * dt +
                                 scale_err * scale_err + interp_err * interp_err) *
                                Eigen::Matrix2d::Identity();
  Q.block<3, 3>(kBias, kBias) = options_.gyro_bias_walk_density * options_.gyro_bias_walk_density *
                                dt * Eigen::Matrix3d::Identity();
  if (use_velocity)
    Q.block<2, 2>(kVel, kVel) = options_.accel_noise_density * options_.accel_noise_density * dt *
                                Eigen::Matrix2d::Identity();
  P_ = F * P_ * F.transpose() + Q;
  P_ = 0.5 * (P_ + P_.transpose());
  capTiltVariance();
}

void AttitudeFilter::capTiltVariance() {
  const double cap = options_.max_tilt_sigma_rad * options_.max_tilt_sigma_rad;
  for (int i = kTilt; i < kTilt + 2; ++i) {
    if (P_(i, i) > cap) {
      const double sc = std::sqrt(cap / P_(i, i));
      P_.row(i) *= sc;
      P_.col(i) *= sc;
    }
  }
}

bool AttitudeFilter::accelTrusted(const Eigen::Vector3d& accel, double dt) {
  const double alpha = dt / (options_.trust_smoothing_s + dt);
  const Eigen::Vector3d previous = smoothed_accel_;
  smoothed_accel_ += alpha * (accel - smoothed_accel_);
  const Eigen::Vector3d f_world = world_R_body_ * accel;
  smoothed_horizontal_ += alpha * (f_world.head<2>() - smoothed_horizontal_);
  const double jerk = (smoothed_accel_ - previous).norm() / dt;
  const double error = std::abs(smoothed_accel_.norm() - options_.gravity_m_s2);
  const double raw_error = std::abs(accel.norm() - options_.gravity_m_s2);
  // A tilt error of theta shows as g sin(theta) of "horizontal acceleration": while the
  // filter itself is that unsure, the disagreement is its own error, not the body's motion.
  const double tilt_sigma = std::sqrt(std::max(P_(kTilt, kTilt), P_(kTilt + 1, kTilt + 1)));
  const double horizontal_limit =
      std::max(options_.untrusted_horizontal_accel_m_s2,
               3.0 * options_.gravity_m_s2 * std::sin(std::min(tilt_sigma, 0.5)));
  const bool trusted = error <= options_.untrusted_accel_error_m_s2 &&
                       raw_error <= 2.0 * options_.untrusted_accel_error_m_s2 &&
                       jerk <= options_.untrusted_jerk_m_s3 &&
                       smoothed_horizontal_.norm() <= horizontal_limit;
  untrusted_for_s_ = trusted ? 0.0 : untrusted_for_s_ + dt;
  // Gravity steady (|f| near g, low jerk) yet "accelerating sideways" for this long: the
  // estimate's tilt is what is wrong (a gyro glitch, say), not the body's motion.
  steady_but_rejected_ = !trusted && untrusted_for_s_ > options_.max_untrusted_s &&
                         error <= options_.untrusted_accel_error_m_s2 &&
                         jerk <= options_.untrusted_jerk_m_s3;
  return trusted || untrusted_for_s_ > options_.max_untrusted_s;
}

Attitude AttitudeFilter::attitude() const {
  if (!initialized_) {
    std::fprintf(stderr, "evermap::imu::AttitudeFilter::attitude() before the first sample\n");
    std::abort();
  }
  const Eigen::Matrix3d Rt = world_R_body_.matrix().transpose();
  const Eigen::Vector3d u = Rt.col(2);
  const Eigen::Vector2d rp = rollPitchFromUp(u);
  // d(roll, pitch)/du, then du/d(dphi_xy) = R^T [e_z]x.
  const double yz2 = std::max(u.y() * u.y() + u.z() * u.z(), 1e-12);
  const double cx = std::sqrt(std::max(1.0 - u.x() * u.x(), 1e-12));
  Eigen::Matrix<double, 2, 3> J_u;
  J_u << 0, u.z() / yz2, -u.y() / yz2, -1.0 / cx, 0, 0;
  const Eigen::Matrix2d J = J_u * Rt * ezCrossXY();
  Attitude a;
  a.utime = utime_;
  a.roll_rad = rp[0];
  a.pitch_rad = rp[1];
  a.covariance = J * P_.block<2, 2>(kTilt, kTilt) * J.transpose();
  a.accel_trusted = last_trusted_;
  return a;
}

}  // namespace evermap::imu
