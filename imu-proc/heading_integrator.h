#pragma once
// The gyro's heading: the yaw rate about the world vertical, with the gyro bias removed,
// integrated over time. Published with the attitude (ATTITUDE heading_rad) so that the mapper
// can turn the body by the gyro, not by the wheels, while vision is blind (dark rooms, blank
// walls, the elevator cab): wheel odometry measures rotation badly (slip, turning in place);
// a gyro measures nothing else. The paper uses the IMU for roll and pitch only (section IV-A)
// and names wheel odometry and the IMU together as what keeps the system going where vision
// fails (section VI); this is that for yaw.
//
// Yaw is unobservable from gravity, and so is the gyro's bias about the vertical: it is
// estimated whenever the body is still (a zero-rate update, ZARU): over a window of
// still_window_s in which every gyro reading stays within still_gyro_spread_rad_s of the
// window's mean and every accelerometer reading within still_accel_spread_m_s2 of its mean,
// the mean gyro reading is a measurement of the bias with variance noise_density² / window.
// The bias is a random walk in between (bias_walk_density). A robot stops often (goals,
// doors, elevators); one that never stops keeps the initial uncertainty, which the message
// reports (heading_rate_sigma_rad_s), so the consumer weighs the gyro accordingly.
//
//   yaw rate r = e_zᵀ world_R_body (ω - b̂)      heading += ½ (r_prev + r) dt
//
// world_R_body's roll and pitch come from the AttitudeFilter (its yaw does not matter for e_z).

#include <cstdint>
#include <deque>

#include <Eigen/Core>

#include "core/common/expected.h"
#include "core/common/option_fields.h"
#include "core/geometry/so3.h"
#include "core/imu/sample_gate.h"

namespace evermap::imu {

struct HeadingOptions {
  // Gyro white noise, rad/s/sqrt(Hz), and bias random walk, rad/s^2/sqrt(Hz).
  double noise_density = 1e-3;
  double bias_walk_density = 1e-4;
  // Before any still window: the bias is unknown to this 1 sigma (rad/s). A MEMS gyro's
  // turn-on bias is of the order of 0.1-1 deg/s.
  double initial_bias_sigma_rad_s = 0.02;
  // A still window: this long, every reading within these spreads of the window's mean.
  double still_window_s = 1.0;
  double still_gyro_spread_rad_s = 0.01;
  double still_accel_spread_m_s2 = 0.1;
  // ... and its mean rate within this of the current bias estimate plus 3 sigma of it (a slow,
  // steady turn is not a bias).
  double still_max_rate_rad_s = 0.02;
  // A gap between samples longer than this restarts the integration (heading_valid stays, the
  // heading continues from its last value; the gap's rotation is unknown and not counted).
  double max_gap_s = 0.5;

  Status validate() const;
  // Every setting once: key, unit, range, doc (core/common/option_fields.h).
  void declareOptions(OptionList& o) {
    o.add("noise_density", &noise_density, "rad/s/sqrt(Hz)", "gyro white noise").positive();
    o.add("bias_walk_density", &bias_walk_density, "rad/s^2/sqrt(Hz)", "gyro bias random walk")
        .nonNegative();
    o.add("initial_bias_sigma_rad_s", &initial_bias_sigma_rad_s, "rad/s",
          "bias sigma before any still window")
        .positive();
    o.add("still_window_s", &still_window_s, "s", "a still window lasts this long ...").positive();
    o.add("still_gyro_spread_rad_s", &still_gyro_spread_rad_s, "rad/s",
          "... with every gyro reading within this")
        .positive();
    o.add("still_accel_spread_m_s2", &still_accel_spread_m_s2, "m/s^2",
          "... and every accelerometer reading within this")
        .positive();
    o.add("still_max_rate_rad_s", &still_max_rate_rad_s, "rad/s",
          "... and its mean rate within this of the bias")
        .positive();
    o.add("max_gap_s", &max_gap_s, "s", "a longer gap restarts the integration").positive();
  }
};

struct HeadingCounts {
  int64_t still_updates = 0;  // zero-rate updates of the bias
  int64_t gaps = 0;           // sample gaps over max_gap_s
};

class HeadingIntegrator {
 public:
  // Contract: options.validate() is ok (checked; aborts otherwise).
  explicit HeadingIntegrator(const HeadingOptions& options = {});

  // One gyro/accelerometer sample (already through the SampleGate) and the body's attitude
  // at it.
  void add(const ImuSample& sample, const core::SO3d& world_R_body);

  bool started() const { return started_; }
  // The utime of the sample the current integration started at: the first, or the end of the
  // last gap over max_gap_s (0 before the first sample).
  int64_t epoch() const { return epoch_; }
  double headingRad() const { return heading_; }
  // 1 sigma of the bias about the vertical left in the heading rate, rad/s.
  double rateSigmaRadS() const;
  const Eigen::Vector3d& bias() const { return bias_; }
  const HeadingCounts& counts() const { return counts_; }

 private:
  void stillness(const ImuSample& s);

  HeadingOptions o_;
  bool started_ = false;
  int64_t utime_ = 0;
  int64_t epoch_ = 0;
  double heading_ = 0.0;
  double rate_ = 0.0;  // yaw rate at the last sample, rad/s
  Eigen::Vector3d bias_ = Eigen::Vector3d::Zero();
  double bias_var_ = 0.0;                               // per axis, rad²/s²
  Eigen::Vector3d up_body_ = Eigen::Vector3d::UnitZ();  // world vertical in the body frame
  std::deque<ImuSample> window_;                        // the current still-window candidate
  HeadingCounts counts_;
};

}  // namespace evermap::imu
