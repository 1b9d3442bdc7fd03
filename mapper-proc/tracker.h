#pragma once
// Tracking of Δ_t^a, the pose of the robot's body relative to the active node, with its
// covariance (paper section III-B.1, eq. 5-7).
//
// Visual odometry arrives as ref_T_cur of the camera against its reference keyframe; the
// keyframe chain is compounded into Δ at every keyframe change (eq. 6-7), and the frames in
// between ride on top as a pending offset. When VO fails, or is silent for vo_timeout_s
// (vo-proc killed, messages lost), the last good frame is committed and wheel odometry
// increments from that frame on are compounded instead (a few seconds of them are kept for
// that) until VO is back. The VO_DELTA contract (docs/contracts.md) and what the tracker does:
//  - status OK, the known reference: the motion rides on the reference's commit point. After
//    a gap in which VO failed but kept its reference, the wheel increments since that
//    reference are taken back and VO's motion replaces them (relinked), unless the two
//    disagree (relink_gate): then the frame is reanchored as below.
//  - status OK, a reference the tracker does not know (a lost keyframe change, a restarted
//    vo-proc): the frame is placed where the estimate (VO's last frame, or wheel odometry)
//    put the body and the chain continues from there (reanchored). A lost keyframe change
//    while VO tracks: the motion since the last frame taken comes from the two frames'
//    odometry poses (odometry_bridged); so does the motion over a silence (a partition of the
//    link) the wheels carried, when the poses span it and agree with the wheels as a relink
//    must. Never refused: an unknown reference must not freeze the map.
//  - keyframe_changed with a status other than OK (NO_DATA: VO's first frame; a failure: the
//    chain breaks): this frame is the new reference, at the current estimate.
// Everything is expressed in the body frame: a camera motion D becomes
// body_T_cam D cam_T_body, covariance Ad(body_T_cam) Σ Ad(body_T_cam)ᵀ (right perturbations).
//
// While wheel odometry carries Δ, the gyro turns it: each wheel increment's yaw is fused
// (information-weighted, a Kalman update on θ) with the heading change imu-proc's ATTITUDE
// reports over the same interval (heading_rad, interpolated), whose variance comes from the
// bias uncertainty it reports. Wheels measure rotation badly (slip, turning in place in the
// elevator cab); the gyro's yaw is what keeps a floor's heading through a blind stretch.
// A VO keyframe step is fused with the gyro's yaw the same way; one whose yaw the gyro
// contradicts (TrackerOptions::vo_gyro_gate) is a VO failure VO did not report, and the
// wheels carry Δ over it; on a failure, so is VO's motion since its reference (loseVo). A
// keyframe step the newest heading does not reach waits for it
// (TrackerOptions::heading_wait_s). Its translation is fused, before the gyro's yaw, with the
// wheels' over the same interval, from the increments kept while VO tracks
// (TrackerOptions::wheel_translation).
//
// A bounded history of the committed increments lets the mapper compound q_T_now, the motion
// since a recent keyframe q, when a registration of q comes back.

#include <cstdint>
#include <deque>
#include <optional>
#include <string>

#include <evermap/attitude_t.hpp>
#include <evermap/vo_delta_t.hpp>
#include <evermap/wheel_odom_t.hpp>

#include "core/common/expected.h"
#include "core/common/option_fields.h"
#include "core/geometry/se3.h"
#include "core/map/map_snapshot.h"
#include "core/messages/odometry_frame.h"
#include "mapper-proc/tracker_counts.h"

namespace evermap::mapper {

using core::Mat6;
using core::SE3d;
using core::UncertainPose;

struct TrackerOptions {
  SE3d body_T_cam;  // left camera on the body
  // Wheel odometry is planar: per increment, the unobserved height, roll and pitch get these
  // standard deviations (metres, radians) so that Δ's covariance stays positive definite.
  double wheel_offplane_sigma_m = 0.001;
  double wheel_offplane_sigma_rad = 0.001;
  // Committed increments kept for registrations that come back late, seconds of message time.
  double history_s = 30.0;
  // VO silent this long (seconds of message time, seen from WHEEL_ODOM): wheel odometry
  // takes over from the last VO frame.
  double vo_timeout_s = 0.5;
  // Wheel increments kept while VO tracks, to bridge from the last good VO frame when VO
  // fails (its failure message comes after wheel messages it covers); seconds.
  double wheel_buffer_s = 5.0;
  // χ²(3) gate (x, y, yaw) of VO's motion over a failure gap against the wheels' before VO's
  // replaces it (relink); 16.27 = 99.9 %.
  double relink_gate = 16.27;
  // The gyro's heading (ATTITUDE heading_rad) fused into wheel increments' yaw.
  bool gyro_heading = true;
  // The wheels' translation over a VO keyframe step fused into the step's (an EKF update by
  // the two covariances): VO's scale is weak where every feature is far ahead (a near-blank
  // corridor), where its covariance grows and the wheels' carries the step; a wheel slip,
  // which the wheels' covariance does not know, moves a step VO measured well by little.
  // Off: VO's translation alone, for wheels whose covariance is far from true (a skid-steered
  // base turning, legs).
  bool wheel_translation = true;
  // χ²(1) gate of VO's yaw over a keyframe step against the gyro's over the same interval,
  // each with its variance: a step beyond it is a VO failure that VO did not report (a turn
  // seen in moving texture, a wrong match of the new keyframe), and with wheel odometry at
  // hand the wheels (with the gyro) carry Δ from the step's reference instead, as after a
  // reported failure; without it (no wheels, or wheels that stopped or lag by more than two
  // of their periods) the step keeps VO's motion with the gyro's yaw fused. A step from a
  // reanchored reference (the one after a contradiction among them) is tested but not fused:
  // its reference was placed by the wheels, not by VO, so on a contradiction the wheels carry
  // Δ from where it had the body when the reference was placed. 0: no
  // test. 16 (99.99 %): on the rendered 3-floor sessions (evermap-slam-run, seeds 2-8) 0-9
  // steps a run, node ATE mean 0.189 -> 0.164 m, no seed worse (docs/mapper.md, "A year",
  // ninth pass); 9 and 30 measured alike on seeds 4 and 7.
  double vo_gyro_gate = 16.0;
  // How long a VO keyframe step waits for the gyro's heading to cover it, seconds of message
  // time. imu-proc's ATTITUDE (50 Hz) lags VO's frames by up to a period; a step taken at
  // once met a heading extrapolated over that lag, whose variance
  // (heading_extrapolation_rate_sigma_rad_s × lag)² made the gyro's yaw worth nothing against
  // VO's: 0.57° at 10 ms, so a 1° turn VO saw in a featureless stretch passed the
  // vo_gyro_gate and was not fused away (rendered 3-floor seed 3: 73 % of the keyframe steps
  // met a lag of 3-13 ms). A step the newest heading does not reach is held (its motion is
  // in Δ, its commit, gyro test and fusion wait) until a heading reaches it, or until a later
  // VO frame, a FLOOR message (the mapper) or a WHEEL_ODOM more than this past it arrives:
  // then it is taken with what there is. Only while headings come (the newest within 1 s);
  // 0: never held. Below vo_timeout_s (the wheels' takeover must find no step held).
  double heading_wait_s = 0.1;
  // Gyro white noise, rad/s/sqrt(Hz), and how long the reported bias error stays the same,
  // seconds: increments are compounded as independent, so each gets the share
  // σ_b² dt T of a bias error σ_b that is in fact common to T seconds of them.
  double gyro_noise_density = 1e-3;
  double gyro_bias_correlation_s = 10.0;
  // A wheel increment ending this far past the newest ATTITUDE uses the heading extrapolated
  // at its last rate (imu-proc's messages lag the wheels' a little), seconds.
  double heading_extrapolation_s = 0.1;
  // ... and the extrapolated span τ is good only to the turn rate's change over it: its yaw
  // gets the variance (heading_extrapolation_rate_sigma_rad_s τ)². A turn that starts or
  // stops within τ changes the rate by the whole turn rate (robots turn in place at up to
  // ~1 rad/s; the simulator at 0.8). Without it an extrapolated heading counted as measured:
  // with ATTITUDE one 10 Hz tick behind the wheels, the rides' yaw errors doubled
  // (docs/mapper.md, "A year").
  double heading_extrapolation_rate_sigma_rad_s = 1.0;
  // Plausibility of an odometry message's content (issue 17): a VO_DELTA or WHEEL_ODOM whose
  // motion implies more than these rates over its time span is refused and counted, as a
  // malformed one is. Physics bounds, not noise gates: 50 m/s is above any ground robot or
  // car in our data (KITTI: up to ~15 m/s), 20 rad/s above a hand-held camera's turns; spans
  // shorter than 1 ms count as 1 ms.
  double max_speed_m_s = 50.0;
  double max_turn_rad_s = 20.0;

  // The tracker.* settings (core/common/option_fields.h); body_T_cam is the program's.
  void declareOptions(OptionList& o) {
    o.add("wheel_offplane_sigma_m", &wheel_offplane_sigma_m, "m",
          "height sigma given to each planar wheel increment")
        .positive();
    o.add("wheel_offplane_sigma_rad", &wheel_offplane_sigma_rad, "rad",
          "roll and pitch sigma given to each planar wheel increment")
        .positive();
    o.add("history_s", &history_s, "s", "committed increments kept for late registrations")
        .positive();
    o.add("vo_timeout_s", &vo_timeout_s, "s", "VO silent this long: wheel odometry takes over")
        .positive();
    o.add("wheel_buffer_s", &wheel_buffer_s, "s", "wheel increments kept to bridge a VO failure")
        .nonNegative();
    o.add("relink_gate", &relink_gate, "chi2(3)",
          "gate of VO's motion over a failure gap against the wheels'")
        .positive();
    o.add("gyro_heading", &gyro_heading, "fuse the gyro's heading into wheel increments' yaw");
    o.add("wheel_translation", &wheel_translation,
          "fuse the wheels' translation into VO's keyframe steps");
    o.add("gyro_noise_density", &gyro_noise_density, "rad/s/sqrt(Hz)", "gyro white noise")
        .positive();
    o.add("gyro_bias_correlation_s", &gyro_bias_correlation_s, "s",
          "how long the gyro's bias error stays the same")
        .positive();
    o.add("vo_gyro_gate", &vo_gyro_gate, "chi2(1)",
          "gate of VO's yaw over a keyframe step against the gyro's; 0: no test")
        .nonNegative();
    o.add("heading_extrapolation_rate_sigma_rad_s", &heading_extrapolation_rate_sigma_rad_s,
          "rad/s", "turn-rate change assumed over an extrapolated heading's span")
        .nonNegative();
    o.add("heading_extrapolation_s", &heading_extrapolation_s, "s",
          "a wheel increment this far past the newest heading extrapolates it")
        .nonNegative();
    o.add("heading_wait_s", &heading_wait_s, "s",
          "a VO step waits this long for a heading to cover it (below vo_timeout_s); 0: never")
        .nonNegative();
    o.add("max_speed_m_s", &max_speed_m_s, "m/s", "odometry faster than this is refused")
        .positive();
    o.add("max_turn_rad_s", &max_turn_rad_s, "rad/s", "odometry turning faster is refused")
        .positive();
  }
  Status validate() const;
};

class Tracker {
 public:
  explicit Tracker(const TrackerOptions& options);

  // Each returns an error (and counts a drop) for a message it cannot apply.
  Status addVo(const vo_delta_t& msg);
  // A WHEEL_ODOM after lost ones spans the hole by its odometry pose (bridgeWheelHole).
  Status addWheel(const wheel_odom_t& msg);
  // The gyro's heading from ATTITUDE (messages without heading_valid are ignored).
  Status addHeading(const attitude_t& msg);

  // Δ_t^a: active_T_body now.
  UncertainPose delta() const;
  // The left (rectified) camera on the body, from STEREO_CALIB: VO deltas after this call
  // are taken through it.
  void setBodyTCamera(const SE3d& body_T_cam);
  const SE3d& bodyTCamera() const { return o_.body_T_cam; }
  // A camera motion D and its covariance as the body's: body_T_cam D cam_T_body, the covariance
  // symmetrised.
  UncertainPose toBody(const SE3d& cam_motion, const Mat6& cam_covariance) const;
  // The same with the covariance as the product gives it: a registration's (the mapper's and
  // evermap-slam-run's rows), whose figures were measured so (symmetrising moves the oracle's
  // year run by rounding).
  UncertainPose registrationToBody(const SE3d& cam_T, const Mat6& cam_covariance) const;
  // Re-initialises Δ (new active node, or a registration replacing it).
  void reset(const UncertainPose& active_T_body);
  // Adds a known vertical displacement (an elevator ride), metres, with its standard deviation.
  void addHeight(double dz_m, double sigma_m);

  // The motion since the keyframe at `utime` (keyframe_T_body now), compounded from the
  // increments after it; empty when that keyframe is not in the history.
  std::optional<UncertainPose> sinceKeyframe(int64_t keyframe_utime) const;

  // A VO keyframe step held for its heading (TrackerOptions::heading_wait_s): the keyframe's
  // utime, or -1. Until it is taken, VO's reference is still the one before it.
  int64_t heldKeyframeUtime() const { return held_ ? held_->utime : -1; }
  // Whether the held step is to be taken before a message at `utime`: the headings reach it,
  // or it has waited heading_wait_s.
  bool heldStepDue(int64_t utime) const;
  // Whether the headings now reach the held step.
  bool heldStepCovered() const;
  // Takes the held step now, with the headings at hand (addVo does so first itself, and
  // addWheel once the step has waited heading_wait_s); its keyframe's utime, or empty when
  // none was held. Δ is then at the keyframe.
  std::optional<int64_t> takeHeldStep();

  bool voTracking() const { return vo_mode_; }
  // VO's reference keyframe (utime) while VO tracks; -1 otherwise.
  int64_t referenceUtime() const { return vo_mode_ ? ref_utime_ : -1; }
  int64_t lastUtime() const { return last_utime_; }
  // Distance travelled, metres: the wheels' (every WHEEL_ODOM accepted, whichever mode), or
  // without wheel odometry the path of the increments compounded into Δ.
  double odometerM() const { return last_wheel_received_ ? wheel_odometer_m_ : path_odometer_m_; }
  const TrackerCounts& counts() const { return counts_; }

  // The odometry pose (VO_DELTA odom_*, camera frames) of the frame Δ is at, and the
  // covariance of that frame's own motion from its reference keyframe (its VO_DELTA
  // covariance; zero for a keyframe or a chain restart), for odometryBetween(): set by every
  // VO frame that carries one and moves Δ to itself, cleared when anything else moves Δ on
  // (wheel odometry, a failure) or a frame carries none. A resets() or a height keeps it: Δ is
  // still at that frame.
  using OdometryAnchor = map::OdometryAnchor;  // core/map/map_snapshot.h
  const std::optional<OdometryAnchor>& odometryAtDelta() const { return odometry_at_delta_; }
  // The message time Δ is at: its last VO frame, or the last wheel increment compounded.
  int64_t deltaUtime() const { return delta_utime_; }
  // The wheels' odometry pose (WHEEL_ODOM odom_*) at `utime`, from the last second of them
  // (messages::wheelOdometryAt); empty without two of one epoch around it.
  std::optional<messages::WheelOdometryPose> wheelOdometryAt(int64_t utime) const {
    return messages::wheelOdometryAt(wheel_poses_, utime);
  }
  // A planar motion (x, y, θ) with its covariance over the right tangent's (υx, υy, ωz) as
  // the body's, the unobserved height, roll and pitch given wheel_offplane_sigma_*.
  UncertainPose planarMotion(const Eigen::Vector3d& x, const Eigen::Matrix3d& covariance) const;

  // "" when a motion of `distance_m` and `angle_rad` over [from_utime, to_utime] is within
  // max_speed_m_s and max_turn_rad_s (spans under 1 ms count as 1 ms), else why not.
  std::string implausibleMotion(double distance_m, double angle_rad, int64_t from_utime,
                                int64_t to_utime) const;

 private:
  struct Increment {
    int64_t utime;       // end of the increment (a keyframe's utime in VO mode)
    UncertainPose pose;  // previous commit point _T_ this one
  };
  // A VO frame's motion from its reference (body frames) and its VO covariance (camera's),
  // checked: an error names what is wrong (an implausible motion is counted).
  struct VoMotion {
    UncertainPose ref_T_body;
    Mat6 covariance = Mat6::Zero();
  };
  Expected<VoMotion> checkedMotion(const vo_delta_t& msg);
  // A new reference keyframe (VO's first frame, a chain break) at the current estimate.
  void restartChain(const vo_delta_t& msg, bool ok);
  // Δ is now at msg's frame: its odometry pose (if any) becomes odometryAtDelta().
  void anchorOdometry(const vo_delta_t& msg, const Mat6& own_covariance);
  void commit(int64_t utime, const UncertainPose& increment);
  // VO failed after last_good_utime: its motion since its reference is tested as a step,
  // and the wheels take over.
  void loseVo(int64_t last_good_utime);
  // Leaves VO mode at the last good VO frame (lost_utime) and compounds the buffered wheel
  // increments that end after it.
  void enterWheelMode(int64_t lost_utime);
  // Puts an OK frame against reference `ref_utime` that VO mode does not continue onto Δ.
  // since_last: the body's motion from the last VO frame taken to this one, when their
  // odometry poses span it (odometrySinceLastFrame).
  void rejoin(int64_t ref_utime, const UncertainPose& ref_T_body, int64_t utime,
              const std::optional<UncertainPose>& since_last);
  // VO's motion `vo` since the commit point at from_utime replaces the wheel increments after
  // it, unless the two disagree (relink_gate) or VO's is the less certain (both counted):
  // then nothing changes. Leaves VO mode on at that commit point.
  bool replaceWheels(int64_t from_utime, const UncertainPose& vo);
  // The wheel increments committed after `utime` (and after VO was lost) taken back out of Δ.
  void takeBackWheelsAfter(int64_t utime);
  // The body's motion from the last VO frame taken to `msg`'s, from their odometry poses (one
  // epoch, VO's own chain: what the VO_DELTAs lost in between compounded); empty without them,
  // and after wheels took over other than by a silence (VO's failure, the gyro's veto).
  std::optional<UncertainPose> odometrySinceLastFrame(const vo_delta_t& msg) const;
  // Compounds a wheel increment, or its share after from_utime when it starts before.
  void applyWheel(const wheel_odom_t& msg, int64_t from_utime);
  // Keeps msg's odometry pose (if any) for wheelOdometryAt().
  void keepWheelPose(const wheel_odom_t& msg);
  wheel_odom_t bridgeWheelHole(const wheel_odom_t& msg) const;
  // Wheel odometry from its last increment to `utime` at that increment's rate (a VO restart
  // between two wheel messages).
  void extrapolateWheel(int64_t utime);
  std::optional<wheel_odom_t> last_wheel_;           // the last increment applied
  std::optional<wheel_odom_t> last_wheel_received_;  // the last WHEEL_ODOM taken in
  int64_t lastWheelUtime() const { return last_wheel_received_ ? last_wheel_received_->utime : -1; }
  // The gyro's heading change over [t0, t1] and its variance; empty when the headings kept
  // do not cover the interval.
  std::optional<std::pair<double, double>> gyroYaw(int64_t t0, int64_t t1) const;
  // A VO keyframe step over [t0, t1] with the wheels' translation over the same interval
  // fused in (TrackerOptions::wheel_translation); VO's when they do not cover it.
  UncertainPose withWheelTranslation(int64_t t0, int64_t t1, const UncertainPose& vo);
  // A VO increment over [t0, t1] with the gyro's yaw over the same interval fused in.
  UncertainPose withGyroYaw(int64_t t0, int64_t t1, const UncertainPose& increment);
  // The gyro's yaw over [t0, t1] against the increment's: (innovation, its variance with the
  // increment's), empty without a heading; and whether it contradicts the increment
  // (TrackerOptions::vo_gyro_gate).
  std::optional<std::pair<double, double>> gyroInnovation(int64_t t0, int64_t t1,
                                                          const UncertainPose& increment) const;
  bool gyroContradicts(int64_t t0, int64_t t1, const UncertainPose& increment) const;
  // Whether the wheel increments kept while VO tracks reach back to from_utime and on to
  // to_utime; whether increment w reaches `utime` (within two of its periods: beyond, the
  // wheels are silent, and nothing is extrapolated from them).
  bool wheelsCover(int64_t from_utime, int64_t to_utime) const;
  static bool reaches(const wheel_odom_t& w, int64_t utime);
  // A covariance made exactly symmetric (rounding in products breaks it).
  static Mat6 symmetric(const Mat6& m);
  // The wheels' motion over [t0, t1] (body frames, no gyro) from the increments kept while VO
  // tracks, the end ones by their share, past the last one at its rate; empty when they do
  // not cover the interval (wheelsCover) or do not chain over it (a hole, an overlap).
  std::optional<UncertainPose> wheelMotion(int64_t t0, int64_t t1) const;
  struct HeadingSample {
    int64_t utime;
    double heading_rad;
    double rate_sigma;
    int64_t epoch;  // ATTITUDE heading_epoch (0: not said)
  };
  std::deque<HeadingSample> headings_;
  // Whether the newest heading is at or past `utime`.
  bool headingReaches(int64_t utime) const;
  // A keyframe step [ref_utime, utime] held for its heading; pending_ holds its motion.
  struct HeldStep {
    int64_t ref_utime;
    int64_t utime;
  };
  std::optional<HeldStep> held_;
  // The keyframe step: the gyro's test, the wheels' translation and the gyro's yaw fused in,
  // the commit, the new reference.
  void takeStep(int64_t ref_utime, int64_t utime);
  // A step's test and fusion: contradicted by the gyro's yaw, the wheels carry Δ from its
  // reference (false); else its motion (pending_) gets the wheels' translation (with_wheels)
  // and the gyro's yaw fused in (true). Shared by the keyframe step and the motion before a
  // failure (loseVo).
  bool testStep(int64_t ref_utime, int64_t utime, bool with_wheels);
  // testStep for a step from a reanchored reference: tested by the gyro, not fused.
  bool testReanchoredStep(int64_t ref_utime, int64_t utime);
  // A step the gyro contradicts: Δ keeps `kept` of VO's motion since the last commit point,
  // and the wheels carry it on from `from_utime` (vo_contradicted).
  void handToWheels(const UncertainPose& kept, int64_t from_utime);

  TrackerOptions o_;
  Mat6 ad_body_T_cam_;
  UncertainPose base_;     // active_T_(last commit point)
  UncertainPose pending_;  // (last commit point)_T_body, from VO frames since the keyframe
  bool vo_mode_ = false;
  int64_t ref_utime_ = -1;  // VO's current reference keyframe
  // A reference placed by reanchoring (where the estimate has the body at a frame, through
  // VO's motion to it): the gyro's yaw over an increment from it would count that motion's
  // error once more, so those increments are not fused with the gyro. The time Δ had reached
  // when it was placed (the frame's, or a wheel increment's past it), and VO's motion from the
  // reference to that frame: where the wheels take over when the gyro contradicts VO's step
  // from that reference.
  int64_t reanchored_ref_utime_ = -1;
  int64_t reanchored_at_utime_ = -1;
  UncertainPose reanchored_ref_T_body_;
  int64_t last_vo_utime_ = -1;
  int64_t vo_lost_utime_ = -1;
  int64_t last_utime_ = -1;
  double wheel_odometer_m_ = 0.0;
  double path_odometer_m_ = 0.0;
  std::deque<Increment> history_;
  std::deque<wheel_odom_t> recent_wheel_;  // while VO tracks (wheel_buffer_s)
  std::optional<OdometryAnchor> odometry_at_delta_;
  // The last VO frame's, when VO fell silent (vo_timeout_s) and the wheels took over there.
  std::optional<OdometryAnchor> odometry_at_vo_lost_;
  int64_t delta_utime_ = -1;
  std::deque<messages::WheelOdometryPose>
      wheel_poses_;  // the last second of WHEEL_ODOM odom_*, one epoch
  TrackerCounts counts_;
};

}  // namespace evermap::mapper
