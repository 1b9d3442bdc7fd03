#pragma once
// Roll and pitch of the body from a gyro and an accelerometer (paper section IV-A: the
// accelerometer stops the inclination drift of visual odometry).
//
// An error-state Kalman filter. The nominal state is world_R_body (SO(3); yaw is carried but
// unobservable and never reported) and the gyro bias b_g (body frame). The error state is
//   x = (dphi_x, dphi_y, db_x, db_y, db_z),
// with the tilt error as a LEFT (world-frame) perturbation world_R_body = exp(dphi) R_hat.
// Written this way the tilt error does not rotate with the body: propagation is
//   dphi' = dphi - P_xy R_hat db dt - P_xy R_hat n_g dt,   db' = db + n_bw dt,
// and the yaw component dphi_z never couples into roll/pitch at first order, so it is left
// out (Sola, "Quaternion kinematics for the error-state Kalman filter", 2017, sec. 7.3 for
// the global-error form).
//
// Measurement: the direction of the specific force, z = f / |f|, predicted as
//   u = R_hat^T e_z,   u(dphi) ~ u + R_hat^T [e_z]x dphi,   [e_z]x dphi = (-dphi_y, dphi_x, 0).
// Linear acceleration is the real noise on z. It is modelled as white with a spectral
// density (linear_accel_density), so the correction per second is the same at 10 Hz and at
// 1 kHz. When |f| is far from g or the smoothed jerk is high, gravity is not observable:
// the update is skipped, the covariance grows with the gyro noise and the output says
// accel_trusted = false.
//
// Roll and pitch: R = Rz(yaw) Ry(pitch) Rx(roll) (SO3d::fromRollPitchYaw), so
//   u = R^T e_z = (-sin(pitch), sin(roll) cos(pitch), cos(roll) cos(pitch)).
//
// Accelerometer-only mode (no gyroscope: gyroscope_mode = 0, or auto-detected when every
// gyro reading of the start-up window is exactly 0 on all axes). The gyro bias is not a
// state and the rotation is not propagated; the tilt is a random walk with density
// accel_only_tilt_rate_density, so the filter becomes a low-pass of the gravity direction
// with a time constant of about linear_accel_density / (g * accel_only_tilt_rate_density)
// (0.3 / (9.8 * 0.1) = 0.3 s by default). The vertical specific force up . f that elevator-proc
// uses depends on a tilt error e only as cos(e) = 1 - e^2/2, so a lagging tilt costs little.

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/common/expected.h"
#include "core/common/option_fields.h"
#include "core/geometry/so3.h"
#include "core/imu/attitude.h"
#include "core/imu/sample_gate.h"

namespace evermap::imu {

struct AttitudeFilterOptions {
  double gravity_m_s2 = 9.80665;
  // Gyro white noise (rad/s/sqrt(Hz)) and bias random walk (rad/s^2/sqrt(Hz)). The defaults
  // are a few times a MEMS data sheet (ADIS16448: 2e-4, 2e-5): unmodelled scale errors too.
  double gyro_noise_density = 1e-3;
  // -1: auto (a gyroscope that reads exactly 0 on every axis over the whole start-up window
  // is taken as absent), 0: accelerometer only (the gyro readings are ignored), 1: use it.
  int gyroscope_mode = -1;
  // Accelerometer-only mode: the random walk of the body's tilt, rad/s/sqrt(Hz).
  double accel_only_tilt_rate_density = 0.1;
  double gyro_bias_walk_density = 1e-4;
  // Gyro scale-factor and integration error, as a fraction of each rotation increment: a
  // phone at 10 Hz swung at 5 rad/s loses degrees per step to aliasing; this widens the
  // covariance while the body turns, so gravity pulls the tilt back afterwards.
  double gyro_scale_sigma = 0.03;
  // Multiplies the trapezoidal integration error estimate |w''| dt^3 / 12 taken as noise
  // (sampled rates hide the motion between samples; > 1 is cautious).
  double interpolation_error_scale = 3.0;
  // Linear acceleration treated as noise on the measured specific force, m/s^2/sqrt(Hz).
  // Larger: trusts the gyro longer (smoother, slower to correct).
  double linear_accel_density = 0.3;
  // The velocity prior (0, the default, turns it off): the horizontal velocity, integrated from the
  // specific force, is pulled towards 0 with this sigma every period. A tilt error makes the
  // integrated velocity run away at g * tilt, so bounded motion (a robot, a person, a
  // drone in a room) is told apart from a tilt. On EuRoC V1_01 it gains little (tilt RMS
  // 0.95 -> 0.91 deg with sigma 1 m/s) and a phone carried along a corridor breaks it, so
  // it is off unless a platform asks for it.
  double velocity_prior_sigma_m_s = 0.0;
  double velocity_prior_period_s = 2.0;
  // Accelerometer white noise for the velocity integration, m/s^2/sqrt(Hz).
  double accel_noise_density = 0.02;
  // Specific force farther than this from g: gravity not observable, update skipped.
  double untrusted_accel_error_m_s2 = 1.5;
  // Jerk of the smoothed specific force above this: update skipped.
  double untrusted_jerk_m_s3 = 30.0;
  // Horizontal linear acceleration (R f - g e_z in the world, smoothed) above this: update
  // skipped. Catches what |f| cannot: 4 m/s^2 sideways changes |f| by only 0.8 m/s^2.
  double untrusted_horizontal_accel_m_s2 = 1.5;
  // Time constant of the smoothing used for the three tests above.
  double trust_smoothing_s = 0.05;
  // After this long without a trusted sample, the tests are waived (the innovation gate
  // still applies), and if the accelerometer is steady meanwhile the tilt is restarted from
  // it: a tilt estimate gone wrong would otherwise call every sample "accelerating" for ever.
  double max_untrusted_s = 10.0;
  // Updates whose innovation has a Mahalanobis distance^2 above this are rejected (chi^2 with
  // 2 degrees of freedom: 13.8 is p = 0.001).
  double innovation_gate_chi2 = 13.8;
  // When the innovation gate has rejected gravity this long while the accelerometer looked
  // static, the tilt estimate is wrong, not the measurement: restart it from gravity.
  double max_rejected_s = 2.0;
  // Initial uncertainty (after the first sample or a gap).
  double initial_tilt_sigma_rad = 0.1;
  double initial_gyro_bias_sigma_rad_s = 0.05;
  // Start-up: samples over this window are averaged. When the body held still over it (the
  // mean rate and the mean gravity direction of its two halves agree within the limits),
  // the mean gyro is the initial bias estimate.
  double init_window_s = 1.0;
  double still_gyro_spread_rad_s = 0.01;
  double still_tilt_change_rad = 0.01;
  // A tilt variance above this is capped (the state is then "unknown" anyway).
  double max_tilt_sigma_rad = 1.0;
  SampleGateOptions gate;

  Status validate() const;
  // Every setting once: key, unit, range, doc (core/common/option_fields.h).
  void declareOptions(OptionList& o) {
    o.add("gravity_m_s2", &gravity_m_s2, "m/s^2", "gravity's magnitude").positive();
    o.add("gyro_noise_density", &gyro_noise_density, "rad/s/sqrt(Hz)", "gyro white noise")
        .positive();
    o.add("gyroscope_mode", &gyroscope_mode, "",
          "-1 auto, 0 accelerometer only, 1 use the gyroscope")
        .in(-1, 1);
    o.add("accel_only_tilt_rate_density", &accel_only_tilt_rate_density, "rad/s/sqrt(Hz)",
          "tilt random walk in accelerometer-only mode")
        .positive();
    o.add("gyro_bias_walk_density", &gyro_bias_walk_density, "rad/s^2/sqrt(Hz)",
          "gyro bias random walk")
        .nonNegative();
    o.add("gyro_scale_sigma", &gyro_scale_sigma, "", "relative gyro scale error of each increment")
        .nonNegative();
    o.add("interpolation_error_scale", &interpolation_error_scale, "",
          "weight of the interpolation error")
        .nonNegative();
    o.add("linear_accel_density", &linear_accel_density, "m/s^2/sqrt(Hz)",
          "linear acceleration as noise")
        .positive();
    o.add("velocity_prior_sigma_m_s", &velocity_prior_sigma_m_s, "m/s", "velocity prior sigma")
        .nonNegative();
    o.add("velocity_prior_period_s", &velocity_prior_period_s, "s",
          "velocity prior applied this often")
        .positive();
    o.add("accel_noise_density", &accel_noise_density, "m/s^2/sqrt(Hz)",
          "accelerometer white noise")
        .positive();
    o.add("untrusted_accel_error_m_s2", &untrusted_accel_error_m_s2, "m/s^2",
          "|a| this far from g: accelerometer untrusted")
        .positive();
    o.add("untrusted_jerk_m_s3", &untrusted_jerk_m_s3, "m/s^3",
          "jerk above this: accelerometer untrusted")
        .positive();
    o.add("untrusted_horizontal_accel_m_s2", &untrusted_horizontal_accel_m_s2, "m/s^2",
          "horizontal acceleration above this: untrusted")
        .positive();
    o.add("trust_smoothing_s", &trust_smoothing_s, "s", "trust smoothed over this").nonNegative();
    o.add("max_untrusted_s", &max_untrusted_s, "s", "untrusted at most this long").positive();
    o.add("innovation_gate_chi2", &innovation_gate_chi2, "", "gate of an accelerometer update")
        .positive();
    o.add("max_rejected_s", &max_rejected_s, "s", "updates rejected at most this long").positive();
    o.add("initial_tilt_sigma_rad", &initial_tilt_sigma_rad, "rad", "tilt sigma at start")
        .positive();
    o.add("initial_gyro_bias_sigma_rad_s", &initial_gyro_bias_sigma_rad_s, "rad/s",
          "gyro bias sigma at start")
        .nonNegative();
    o.add("init_window_s", &init_window_s, "s", "still start window").nonNegative();
    o.add("still_gyro_spread_rad_s", &still_gyro_spread_rad_s, "rad/s",
          "still: gyro rates within this")
        .nonNegative();
    o.add("still_tilt_change_rad", &still_tilt_change_rad, "rad",
          "still: gravity direction within this")
        .nonNegative();
    o.add("max_tilt_sigma_rad", &max_tilt_sigma_rad, "rad",
          "tilt sigma capped here (at least the initial)")
        .positive();
    o.nest("gate_", &gate);
  }
};

struct AttitudeFilterCounts {
  int64_t updates = 0;    // accelerometer corrections applied
  int64_t untrusted = 0;  // samples where gravity was not observable
  int64_t innovation_rejected = 0;
  int64_t resets = 0;           // re-initialisations after a gap
  int64_t recoveries = 0;       // tilt restarted from gravity (max_rejected_s of gate
                                // rejections, or max_untrusted_s of steady "acceleration")
  int64_t velocity_resets = 0;  // velocity prior rejected: integrated velocity restarted
  bool still_start = false;     // the start-up window was still: gyro bias from it
  bool accel_only = false;      // no gyroscope (gyroscope_mode 0, or auto and none seen)
  std::string summary() const;
};

class AttitudeFilter {
 public:
  // Error state: tilt (2), gyro bias (3), horizontal velocity (2).
  static constexpr int kStateSize = 7;

  // Contract: options.validate() is ok (checked; aborts otherwise).
  explicit AttitudeFilter(const AttitudeFilterOptions& options = {});

  // Feeds one sample. Returns true when the sample was used and attitude() is new; false
  // when the gate dropped it (see gateCounts()).
  bool add(const ImuSample& sample);

  bool initialized() const { return initialized_; }
  // True once the start-up window decided there is no gyroscope (or gyroscope_mode = 0).
  bool accelOnly() const { return counts_.accel_only; }
  // Contract: initialized().
  Attitude attitude() const;
  const Eigen::Vector3d& gyroBias() const { return bias_; }
  const SampleGateCounts& gateCounts() const { return gate_.counts(); }
  const AttitudeFilterCounts& counts() const { return counts_; }

 private:
  void initialize(const ImuSample& s);
  void finishStartup();
  void propagate(const ImuSample& s, double dt);
  void capTiltVariance();
  void applyVelocityPrior();
  // One Kalman update; false (and no change) when the innovation fails the chi^2 gate.
  template <int M>
  bool update(const Eigen::Matrix<double, M, 1>& r, const Eigen::Matrix<double, M, kStateSize>& H,
              const Eigen::Matrix<double, M, M>& R);
  bool accelTrusted(const Eigen::Vector3d& accel, double dt);
  void correct(const Eigen::Vector3d& accel);

  AttitudeFilterOptions options_;
  SampleGate gate_;
  AttitudeFilterCounts counts_;
  bool initialized_ = false;
  int64_t utime_ = 0;
  core::SO3d world_R_body_;
  Eigen::Vector3d bias_ = Eigen::Vector3d::Zero();
  Eigen::Vector2d velocity_ = Eigen::Vector2d::Zero();  // horizontal, world frame, m/s
  double since_velocity_prior_s_ = 0;
  Eigen::Matrix<double, kStateSize, kStateSize> P_ =
      Eigen::Matrix<double, kStateSize, kStateSize>::Identity();
  Eigen::Vector3d smoothed_accel_ = Eigen::Vector3d::Zero();
  Eigen::Vector2d smoothed_horizontal_ = Eigen::Vector2d::Zero();  // world, m/s^2
  double untrusted_for_s_ = 0;
  double rejected_for_s_ = 0;
  bool steady_but_rejected_ = false;
  Eigen::Vector3d last_gyro_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d prev_gyro_ = Eigen::Vector3d::Zero();
  bool last_trusted_ = false;
  std::vector<ImuSample> startup_;  // samples of the start-up window
};

}  // namespace evermap::imu
