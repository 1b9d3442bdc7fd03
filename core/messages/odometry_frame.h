#pragma once
// The odometry frame of a VO_DELTA stream (REP-105's "odom"; docs/contracts.md, VO_DELTA):
// every frame's pose odom_T_cur in a frame fixed where the keyframe chain (re)started, so
// that a consumer that missed messages (a restarted mapper-proc) gets the motion between two
// frames it holds from their poses alone, with the covariance it would have compounded had
// it received every message in between.
//
// OdometryFrame follows the stream in the order the sender publishes it and stamps each
// message's odom_* fields: the chain's keyframe motions compounded (paper eq. 6-7), the
// current frame riding on its reference, as mapper-proc's tracker compounds them
// (tracker.h). The epoch is the utime of the frame the chain started at; a new one begins at
// every chain restart of the contract (keyframe_changed with ref_utime == utime or a status
// other than OK: VO's first frame, a chain break, a restarted vo-proc) and at a keyframe on a
// reference this frame does not know (a sender that lost its own chain). A failure status
// without keyframe_changed keeps VO's reference: that frame has no pose (odom_epoch 0), the
// epoch goes on, and the next OK frame on the reference continues it.
//
// odometryBetween(): the motion a_T_b between two frames of one epoch, b after a. Both
// covariances are accumulated along one chain: for a keyframe a on b's chain,
//   Σ_b = Ad(b_T_a) Σ_a Ad(b_T_a)ᵀ + Σ_ab   (eq. 7 with J1 = Ad(a_T_b⁻¹), J2 = I),
// so Σ_ab is the difference. A frame a that rides on its reference k (not a keyframe) is not
// on b's chain (k → ... → b): the difference then lacks a's own motion from k twice, once
// taken away with Σ_a and once never added, since a_T_b = (k_T_a)⁻¹ k_T_b. The caller gives
// a's own covariance (its VO_DELTA covariance; zero for a keyframe) and it is added back
// twice, transported to b. Rounding can leave the difference a little indefinite: negative
// eigenvalues are set to zero.

#include <cstdint>
#include <optional>
#include <string>

#include <deque>

#include <Eigen/Core>
#include <evermap/vo_delta_t.hpp>
#include <evermap/wheel_odom_t.hpp>

#include "core/common/expected.h"
#include "core/geometry/se2.h"
#include "core/geometry/se3.h"

namespace evermap::messages {

// A frame's pose in its odometry frame, as a VO_DELTA carries it (camera frames).
struct OdometryPose {
  int64_t epoch = 0;  // utime of the frame the odometry frame started at
  int64_t utime = 0;  // the frame's
  core::UncertainPose odom_T_cam;
};

// The pose `m` carries; empty when it carries none (odom_epoch 0), or when its fields are no
// pose (not finite, a quaternion that is not unit, a covariance that is not symmetric
// positive semi-definite): then `why` (if given) says which.
std::optional<OdometryPose> odometryPose(const evermap::vo_delta_t& m, std::string* why = nullptr);

// The motion a_T_b between two poses of one epoch, b after a, and its covariance (above);
// a_own_covariance: the covariance of a's motion from its reference keyframe (zero when a
// is a keyframe). An error for poses of different epochs or b not after a.
Expected<core::UncertainPose> odometryBetween(const OdometryPose& a,
                                              const core::Mat6& a_own_covariance,
                                              const OdometryPose& b);

// Stamps a VO_DELTA stream with odometry poses (above): one per sender, messages in order.
class OdometryFrame {
 public:
  // Fills m's odom_* fields from m's other fields and the frames before it.
  void stamp(evermap::vo_delta_t& m);
  // The current epoch (0 before the first frame and while the chain is unknown).
  int64_t epoch() const { return epoch_; }

 private:
  void startEpoch(int64_t utime);
  int64_t epoch_ = 0;
  int64_t ref_utime_ = -1;  // the reference keyframe the next frames ride on
  core::UncertainPose odom_T_ref_;
};

// The wheels' odometry frame (WHEEL_ODOM odom_*): planar, Smith-Self-Cheeseman on (x, y, θ)
// (core/geometry/se2.h). Compounding b = a ⊕ d gives Σ_b = J1 Σ_a J1ᵀ + J2 Σ_d J2ᵀ, and the
// J1 of a chain compose (J1 of a → m → b is J1 of a → b: a shear by the displacement), so
// the covariance of the increments between two poses of one epoch is recovered exactly:
// Σ_d = J2⁻¹ (Σ_b − J1 Σ_a J1ᵀ) J2⁻ᵀ. The epoch starts at the sender's first increment and
// again wherever an increment does not begin where the previous one ended (a hole: motion
// nothing measured).
struct WheelOdometryPose {
  int64_t epoch = 0;  // utime the integration started at
  int64_t utime = 0;
  core::SE2d odom_T_body;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  // over (x, y, θ) in the odometry frame
};
// A planar motion a_T_b and its covariance over (x, y, θ) expressed in a's frame (SSC).
struct PlanarMotion {
  core::SE2d a_T_b;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
};

// The pose `m` carries; empty when it carries none (odom_epoch 0) or its fields are no pose
// (not finite, a covariance not symmetric positive semi-definite): then `why` says which.
std::optional<WheelOdometryPose> wheelOdometryPose(const evermap::wheel_odom_t& m,
                                                   std::string* why = nullptr);
// The motion between two poses of one epoch, b not before a; an error otherwise.
Expected<PlanarMotion> wheelOdometryBetween(const WheelOdometryPose& a, const WheelOdometryPose& b);
// The pose at `utime` from recent poses of one epoch in time order: interpolated at constant
// rate between the two around it, or past the newest at the rate of the last increment for
// at most two of its lengths (variance: the share's, and as much again for the change of
// speed it cannot see). Empty when utime is before the oldest, further past the newest, or
// fewer than two poses are kept (one pose: only its own time).
std::optional<WheelOdometryPose> wheelOdometryAt(const std::deque<WheelOdometryPose>& poses,
                                                 int64_t utime);

// Stamps a WHEEL_ODOM stream with odometry poses (above): one per sender, messages in order.
class WheelOdometryFrame {
 public:
  void stamp(evermap::wheel_odom_t& m);
  int64_t epoch() const { return pose_.epoch; }

 private:
  WheelOdometryPose pose_;
};

}  // namespace evermap::messages
