#pragma once
// Roll and pitch error of an attitude track against ground-truth poses (world z up).

#include <string>
#include <vector>

#include "imu-proc/attitude_filter.h"
#include "tools/datasets/euroc.h"

namespace evermap::imu {

struct AttitudeErrorSummary {
  int matched = 0;  // estimates with a ground-truth pose within max_offset
  double roll_rms_rad = 0;
  double pitch_rms_rad = 0;
  double roll_max_rad = 0;
  double pitch_max_rad = 0;
  // Fraction of errors inside the reported 3-sigma bound (a consistency figure).
  double within_3_sigma = 0;
  // With align_gravity: the angle between the ground truth's world z and the gravity
  // direction found by the alignment.
  double world_tilt_rad = 0;
  // With align_body: the angle of the fitted rotation between ground-truth body and IMU.
  double body_offset_rad = 0;
  double tilt_rms_rad = 0;  // angle between estimated and reference up, frame-independent
  std::string summary() const;
};

// Compares each estimate with the ground-truth orientation interpolated at its time between
// the two poses around it (each at most max_offset_s away; ground truth sorted by time). Estimates
// before skip_s from the first are left out (the filter's start-up).
//
// A motion-capture world frame need not be level. With align_gravity the gravity direction
// in the ground truth's world frame is estimated first (2 degrees of freedom, the mean of
// world_R_body * up_estimated over all matches, as an ATE alignment estimates its 6 or 7),
// and the reference roll and pitch are taken relative to it.
struct AttitudeCompareOptions {
  double max_offset_s = 0.005;
  double skip_s = 0.0;
  bool align_gravity = false;
  // Also fit a constant rotation between the ground truth's body frame and the IMU frame
  // (a hand-eye calibration; it also absorbs a constant tilt error of the estimate, such as
  // the one an accelerometer bias causes, so report it next to the unaligned figure).
  bool align_body = false;
  // Roll and pitch of a body frame whose z is the mean "up" of the reference (a fixed
  // rotation of the IMU frame), instead of the IMU frame's own. An IMU mounted on its side
  // (EuRoC: x up, pitch -67 deg) has an Euler roll that amplifies tilt errors by
  // 1 / cos(pitch); the level frame reports them as they are.
  bool level_body = false;
  // Roll and pitch of the vehicle frame instead: the IMU frame turned by the smallest
  // rotation that takes vehicle_up_imu (the up direction in IMU coordinates while the
  // vehicle stands level, e.g. meanSpecificForce over a still start) to +z. Taken from the
  // IMU alone, not from the reference. Zero: not used.
  Eigen::Vector3d vehicle_up_imu = Eigen::Vector3d::Zero();
};
// Mean accelerometer reading over [t0, t0 + window_s) from the first sample at or after
// t0_utime (the specific force of a still body points up); zero when no sample falls in the
// window.
Eigen::Vector3d meanSpecificForce(const std::vector<ImuSample>& imu, int64_t t0_utime,
                                  double window_s);

// Is the reference's world z vertical? The angle between its world z and gravity as the
// accelerometer measures it while the body stands still: the mean specific force over
// [t0, t0 + window_s), turned into the world by the reference orientation in the middle of
// the window (the reference's ns stamps rounded to microseconds as the samples' are). Includes
// the accelerometer's bias (0.1 m/s^2 is 0.6 deg). Negative when the reference does not cover
// the window.
double referenceTiltAtRest(const std::vector<ImuSample>& imu,
                           const std::vector<datasets::StampedPose>& ground_truth, int64_t t0_utime,
                           double window_s);

AttitudeErrorSummary compareAttitude(const std::vector<Attitude>& estimates,
                                     const std::vector<datasets::StampedPose>& ground_truth,
                                     const AttitudeCompareOptions& options = {});

}  // namespace evermap::imu
