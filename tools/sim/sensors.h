#pragma once
// Measurement models of the simulated robot: what vo-proc, the wheel encoders, imu-proc and
// elevator-proc would publish, produced from ground truth with noise and failures.
//
// Every model reports the covariance of the noise it actually added ("honest covariances"),
// except for the deliberate faults (wheel slip), which real sensors do not know about either.

#include <cstdint>
#include <vector>

#include <evermap/attitude_t.hpp>
#include <evermap/floor_t.hpp>
#include <evermap/imu_t.hpp>
#include <evermap/vo_delta_t.hpp>
#include <evermap/wheel_odom_t.hpp>

#include "core/camera/calibration.h"
#include "core/common/expected.h"
#include "core/messages/odometry_frame.h"
#include "tools/sim/building.h"
#include "tools/sim/motion.h"
#include "tools/sim/patrol.h"
#include "tools/sim/random.h"

namespace evermap::sim {

// The left camera of the stereo head on the body: camera z forward, x right, y down.
struct CameraOptions {
  double height_m = 1.2;   // above the floor
  double forward_m = 0.1;  // ahead of the body origin
  // Nominal rectified intrinsics, written into KEYFRAME messages.
  double fx = 450.0;
  double fy = 450.0;
  double cx = 376.0;
  double cy = 240.0;
  double baseline_m = 0.12;

  SE3d bodyTCam() const;
  // The rectified stereo calibration of this head for images of width x height (the
  // measurement-level simulator, which renders none, uses 2 cx x 2 cy).
  core::StereoCalibration stereoCalibration(int width, int height) const;
  Status validate() const;
};

// Visual odometry, keyframe to keyframe. A frame becomes the new reference keyframe once the
// camera moved keyframe_translation_m or turned keyframe_rotation_rad from the reference.
// Noise per delta, added on the right (T_meas = T_true * exp(δ)), δ ~ N(0, diag(σt², σr²)):
//   σt = translation_sigma_m + translation_sigma_per_m * d + translation_sigma_per_rad * θ
//   σr = rotation_sigma_rad + rotation_sigma_per_rad * θ + rotation_sigma_per_m * d
// with d, θ the true translation and rotation angle of the delta; the message carries exactly
// this covariance. VO fails (a status, no delta) in dark rooms, while turning at blank walls,
// inside the elevator cab and while passers-by block the view; it restarts with a new
// keyframe (STATUS_NO_DATA) when the view comes back.
struct VoOptions {
  double rate_hz = 20.0;
  double keyframe_translation_m = 0.02;
  double keyframe_rotation_rad = 0.02;
  // Defaults give a median drift of ~0.7 % of distance over uninterrupted indoor stretches
  // at 30 Hz (the summary of evermap-sim-measure prints it).
  double translation_sigma_m = 0.0005;
  double translation_sigma_per_m = 0.02;
  double translation_sigma_per_rad = 0.002;
  double rotation_sigma_rad = 0.0001;
  double rotation_sigma_per_rad = 0.005;
  double rotation_sigma_per_m = 0.01;
  bool fail_in_dark_rooms = true;
  bool fail_at_blank_walls = true;
  bool fail_in_elevator = true;
  double passerby_rate_per_hour = 30.0;  // Poisson; each blocks the view for [min, max] s
  double passerby_min_s = 1.0;
  double passerby_max_s = 5.0;

  Status validate() const;
};

// Planar wheel odometry increments over (x forward, y left, θ), each with noise
//   σx = sigma_m + sigma_forward_per_m * d,  σy = sigma_m + sigma_lateral_per_m * d,
//   σθ = sigma_rad + sigma_theta_per_m * d + sigma_theta_per_rad * |Δθ|,
// reported as the covariance. Slip (Poisson events) scales the measured translation by
// (1 + f), f in [slip_min_fraction, slip_max_fraction], and adds a yaw error of
// slip_yaw_rad_per_m per metre; the covariance does not know.
struct WheelOptions {
  double rate_hz = 10.0;
  double sigma_m = 0.0001;
  double sigma_rad = 0.0001;
  double sigma_forward_per_m = 0.02;
  double sigma_lateral_per_m = 0.005;
  double sigma_theta_per_m = 0.01;
  double sigma_theta_per_rad = 0.02;
  double slip_rate_per_hour = 6.0;
  double slip_min_s = 1.0;
  double slip_max_s = 4.0;
  double slip_min_fraction = 0.05;
  double slip_max_fraction = 0.3;
  double slip_yaw_rad_per_m = 0.05;

  Status validate() const;
};

// Roll and pitch from the IMU, noise σ per angle; accel_trusted is 0 while the body
// accelerates by more than untrusted_accel_mps2 (gravity direction not observable).
//
// With heading: the gyro's heading as imu-proc publishes it (ATTITUDE heading_rad and
// heading_rate_sigma_rad_s; imu-proc/heading_integrator.h), the body's yaw, unwrapped, off by
//  - the bias imu-proc has not removed: drawn N(0, heading_bias_sigma_rad_s²) whenever the
//    body has stood still for heading_still_s (imu-proc's zero-rate update: its estimate from
//    one still window of 1 s is good to the gyro's noise density over √1 s), a random walk
//    of heading_bias_walk_density in between; the message reports its σ;
//  - white noise of heading_noise_density, integrated;
//  - a scale error for the session, N(0, heading_scale_sigma²), times the yaw turned (imu-proc
//    does not estimate it, nor does the tracker's variance know it: an assumption, 0.2 %, of
//    a gyro whose scale was calibrated once).
// Still: level speed below 1 cm/s, acceleration below 0.1 m/s² (imu-proc's still window),
// not turning. A moving cab at constant speed is still for the gyro.
// Off by default (docs/mapper.md, "A year": the gyro in the simulator): ATTITUDE comes after
// the wheels at their shared ticks, so the tracker's gyro yaw over a wheel increment is
// extrapolated and weighs little (TrackerOptions::heading_extrapolation_rate_sigma_rad_s);
// on, it leaves the rides' heading as the wheels make it and changes every figure measured
// without it.
struct AttitudeOptions {
  double rate_hz = 10.0;
  double sigma_rad = 0.003;
  double untrusted_accel_mps2 = 0.25;
  bool heading = false;
  double heading_noise_density = 1e-3;      // rad/s/√Hz
  double heading_bias_sigma_rad_s = 1e-3;   // after a zero-rate update
  double heading_bias_walk_density = 1e-4;  // rad/s²/√Hz
  double heading_scale_sigma = 0.002;
  double heading_still_s = 1.0;

  Status validate() const;
};

// The gyro heading of AttitudeOptions for one session, sampled at the attitude's ticks.
class GyroHeadingModel {
 public:
  GyroHeadingModel(const AttitudeOptions& options, Random rng);
  // Fills m's heading_* at the body state s of time utime (ticks in increasing time).
  void fill(int64_t utime, const BodyState& s, attitude_t* m);

 private:
  AttitudeOptions o_;
  Random rng_;
  double scale_error_ = 0.0;
  double bias_error_ = 0.0;     // rad/s
  double bias_variance_ = 0.0;  // (rad/s)²
  double heading_error_ = 0.0;  // rad
  double unwrapped_yaw_ = 0.0;
  double last_yaw_ = 0.0;
  int64_t last_utime_ = -1;
  int64_t epoch_ = 0;
  double still_s_ = 0.0;
};

// Elevator-proc's output: FLOOR events at ride start and end. The height change of a ride is
// measured with σ = height_sigma_m + height_sigma_per_m * |Δz| and added to the height of the
// departure floor; the arrival floor is the nearest entry of the floor table (the building's
// floors) within match_threshold_m, else -1 with new_floor = 1.
struct FloorOptions {
  double height_sigma_m = 0.03;
  double height_sigma_per_m = 0.005;
  double match_threshold_m = 1.0;

  Status validate() const;
};

// Raw IMU samples, only around elevator rides (from margin_s before a ride starts to margin_s
// after it ends), for testing the elevator detector. Specific force in the body frame plus a
// per-session bias and white noise; angular velocity plus a per-session bias (a MEMS gyro's
// turn-on bias, gyro_bias_sigma_radps per axis) and white noise.
struct ImuOptions {
  bool enabled = true;
  double rate_hz = 50.0;
  double margin_s = 3.0;
  double accel_sigma_mps2 = 0.02;
  double gyro_sigma_radps = 0.002;
  double gyro_bias_sigma_radps = 0.003;
  double accel_bias_sigma_mps2 = 0.02;
  double gravity_mps2 = 9.80665;

  Status validate() const;
};

// Time intervals [begin, end) in microseconds, sorted; drawn as a Poisson process.
class Intervals {
 public:
  Intervals() = default;
  Intervals(int64_t start, int64_t end, double rate_per_hour, double min_s, double max_s,
            Random& rng);
  bool contains(int64_t utime) const;
  size_t size() const { return spans_.size(); }
  const std::vector<std::pair<int64_t, int64_t>>& spans() const { return spans_; }

 private:
  std::vector<std::pair<int64_t, int64_t>> spans_;
};

// Visual odometry state machine: reference keyframe, tracking or lost.
class VoModel {
 public:
  VoModel(const VoOptions& options, const SE3d& body_T_cam, Random rng);
  // One frame. `condition` is vo_delta_t::STATUS_OK or the failure status of this moment.
  vo_delta_t frame(int64_t utime, const BodyState& state, int8_t condition);
  // Ground-truth camera pose of the current reference keyframe.
  const SE3d& referenceTruth() const { return world_T_ref_; }

 private:
  // The frame without its odometry pose.
  vo_delta_t measure(int64_t utime, const BodyState& state, int8_t condition);
  VoOptions o_;
  SE3d body_T_cam_;
  Random rng_;
  bool tracking_ = false;
  int64_t ref_utime_ = 0;
  SE3d world_T_ref_;
  messages::OdometryFrame odometry_frame_;  // odom_* of every frame, as vo-proc stamps them
};

class WheelModel {
 public:
  WheelModel(const WheelOptions& options, Intervals slips, Random rng);
  wheel_odom_t increment(int64_t prev_utime, const BodyState& prev, int64_t utime,
                         const BodyState& cur);

 private:
  WheelOptions o_;
  Intervals slips_;
  Random rng_;
  messages::WheelOdometryFrame
      odometry_frame_;  // odom_* of every increment, as a wheel driver integrates them
};

attitude_t measureAttitude(int64_t utime, const BodyState& state, const AttitudeOptions& o,
                           Random& rng);

// FLOOR events of one session.
std::vector<floor_t> floorEvents(const Building& building, const SessionPlan& plan,
                                 const FloorOptions& options, Random& rng);

// IMU sample; `bias` is the session's accelerometer bias, `gyro_bias` its gyro bias
// (gyroBias()).
imu_t measureImu(int64_t utime, const Trajectory& trajectory, const ImuOptions& o, const Vec3& bias,
                 const Vec3& gyro_bias, Random& rng);

// The accelerometer bias of one session: accel_bias_sigma_mps2 per axis, the first three
// draws of the session's IMU noise stream `rng`.
Vec3 accelBias(const ImuOptions& o, Random& rng);

// The gyro bias of one session: gyro_bias_sigma_radps per axis, from its own random stream
// (so that it changes no other noise of the session).
Vec3 gyroBias(const ImuOptions& o, uint64_t seed, int session);

}  // namespace evermap::sim
