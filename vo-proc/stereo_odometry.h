#pragma once
// Stereo visual odometry in the manner of FOVIS (Huang et al., "Visual odometry and mapping
// for autonomous flight using an RGB-D camera", ISRR 2011; paper section IV-A), on rectified
// stereo pairs:
//
//   per frame: pyramid, FAST (adaptive threshold, bucketing), sub-pixel stereo depth,
//              patch descriptors                          (core/features/stereo_features.h)
//              initial rotation from the top pyramid level (core/registration/rotation_...)
//              matching against the *reference keyframe* in a predicted window
//              inliers by maximum clique, motion by bidirectional reprojection error,
//              covariance                                  (core/registration/...)
//   reference: the frame VO matches against is kept while it yields at least
//              keyframe_inlier_threshold inliers, so drift does not grow while the camera
//              hovers; below that, the current frame becomes the reference.
//   keyframes: a new reference is a keyframe for the map (a KEYFRAME with ORB descriptors,
//              keyframe_changed, the ref_utime of the VO_DELTAs after it) only when the
//              camera has moved keyframe_min_translation_m or turned keyframe_min_rotation_rad
//              since the last keyframe, or when the chain restarts or is bridged. Between
//              keyframes a frame's motion is given from the last keyframe, chained through the
//              references in between with first-order compounding of the covariances
//              (core::compound). The keyframe policy is thus not the inlier threshold, and ORB
//              descriptors are computed for keyframes only.
//
// Failures never throw and never abort: each frame gets a status (values of vo_delta_t).
//  - kBadInput: an image is empty, not gray or not the camera's size. Nothing changes.
//  - kInsufficientFeatures: too few features with depth (dark, blank wall). The frame is
//    never made a reference. The first usable frame after more than max_failed_frames
//    failures becomes the reference without a registration (kNoData, the chain restarts):
//    after a gap the predicted motion is stale, and a search from it aliases on repeated
//    texture.
//  - kInsufficientInliers / kOptimizationFailure / kReprojectionError: the frame does not
//    register to the reference (occlusion, fast motion), nor, retried, to the last frame
//    that registered (when that is not the reference: a motion through it is chained to the
//    reference and the frame becomes the reference), nor, with fast_motion_fraction (RGB-D),
//    to either with the bounds widened for the image motion of a fast rotation (blur, a
//    rolling shutter). The reference is kept for up to
//    max_failed_frames failures in a row (a passer-by); after that the next frame with enough
//    features becomes the reference. With bridge_breaks (the default) its motion is the
//    motion prior (constant velocity, the rotation measured on the top pyramid level) with
//    a covariance inflated per predicted frame (BridgeOptions), status kOk and `bridged`
//    set: the chain goes on with an honest uncertainty instead of a gap. Without it (or with
//    no motion known yet) the chain breaks (keyframe_changed, ref_utime = its own utime):
//    the mapper bridges the gap (wheel odometry), VO restarts from there.
//
// The motion prior: the last frame-to-frame motion (constant velocity), its rotation replaced
// by the rotation measured on the top pyramid level when there is one. It places the search
// windows of the next frame; at ~1 m between frames (a car at 10 Hz) a rotation-only
// prediction leaves near features tens of pixels from where they are.
//
// RGB-D frames (processRgbd) go through the same steps with the camera's equivalent stereo rig
// (core/camera/rgbd_camera.h): only the depth of a feature comes from the depth image instead
// of the right image; VO_DELTA and KEYFRAME do not say which camera made them.
//
// Not thread-safe; one instance per camera stream.

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include <opencv2/core.hpp>

#include "core/camera/stereo_camera.h"
#include "core/common/expected.h"
#include "core/common/option_fields.h"
#include "core/features/orb_descriptor.h"
#include "core/features/stereo_features.h"
#include "core/geometry/se3.h"
#include "core/registration/disparity_offset_tracker.h"
#include "core/registration/frame_registration.h"
#include "core/registration/keyframe_features.h"
#include "core/registration/rotation_estimation.h"
#include "core/registration/window_matcher.h"
#include "vo-proc/rolling_shutter_corrector.h"

namespace evermap::vo {

// Values equal vo_delta_t::STATUS_*.
enum class VoStatus : int8_t {
  kOk = 0,
  kNoData = 1,                // the first usable frame: it becomes the reference
  kInsufficientFeatures = 2,  // dark, blank wall
  kInsufficientInliers = 3,   // occlusion, fast motion
  kOptimizationFailure = 4,
  kReprojectionError = 5,
  kBadInput = 6,  // wrong size, empty image, no valid calibration
};
const char* toString(VoStatus status);

struct OdometryOptions {
  core::StereoFeatureExtractor::Options features = defaultFeatures();
  core::WindowMatchOptions matching;
  // registration.min_features: fewest features with depth for a frame to be used;
  // registration.min_inliers: fewest inliers for a motion to be accepted.
  core::RegistrationOptions registration = defaultRegistration();
  bool estimate_rotation = true;  // initial rotation from the top pyramid level
  core::RotationEstimateOptions rotation;
  // The reference keyframe is replaced when a frame registers with fewer inliers than
  // keyframe_inlier_threshold (FOVIS's ref-frame-change-threshold), or fewer than
  // keyframe_inlier_fraction of the inliers of the first frame registered against it: in a
  // rich scene the motions to a far-away reference are the least accurate (patches deform),
  // and the one at the change is the one that is chained.
  int keyframe_inlier_threshold = 150;
  double keyframe_inlier_fraction = 0.5;
  // A new reference is a map keyframe when the camera has moved at least this far or turned
  // at least this much since the last keyframe (0 and 0: every reference is a keyframe).
  double keyframe_min_translation_m = 0.2;
  double keyframe_min_rotation_rad = 0.087;  // 5 degrees
  // Consecutive failures against the reference before it is replaced.
  int max_failed_frames = 2;
  // Predict the motion since the previous frame as the last frame-to-frame motion (constant
  // velocity); off: rotation only (FOVIS).
  bool constant_velocity = true;
  // A frame that fails against the reference is registered to the last frame that
  // registered (when that is not the reference).
  bool retry_previous_frame = true;
  // Fast motion: a frame that registers neither to the reference nor to the last registered
  // frame is tried once more with the motion estimate's inlier and mean-error bounds widened
  // to this fraction of the image motion the prior predicts (f times its rotation per frame),
  // when that is above the bounds: motion blur and a rolling shutter displace a feature by a
  // share of the image's motion during the exposure and the readout, which a rigid motion
  // between two instants does not model. 0: off (global-shutter stereo rigs).
  double fast_motion_fraction = 0.0;
  // Bridge a chain break with the motion prior (see the class comment).
  bool bridge_breaks = true;
  // Standard deviations of the motion prior, per predicted frame (variances add up over the
  // frames of a gap): a floor plus a fraction of the predicted motion itself.
  struct BridgeOptions {
    double translation_sigma_m = 0.05;
    double rotation_sigma_rad = 0.02;
    double velocity_fraction = 0.3;  // of the predicted translation and rotation
  } bridge;
  // ORB descriptors of keyframes (for loop closure); off saves their cost.
  bool keyframe_descriptors = true;
  core::OrbExtractor::Options orb;
  // Self-calibration: the rig's disparity offset estimated from the frames registered to the
  // reference (core/registration/disparity_offset_tracker.h) and, once it has converged to a
  // significant value, applied to the camera (stereo rigs; an RGB-D camera has no offset).
  bool self_calibrate = true;
  core::DisparityOffsetTrackerOptions self_calibration;
  // A rolling shutter (rolling_shutter_corrector.h): the camera's line delay, the time between
  // two rows' exposures (microseconds per row; 0: a global shutter), the features are
  // corrected with. A Kinect's color camera: docs/rgbd.md, "Rolling shutter".
  double line_delay_us = 0.0;
  // The registered pairs gathered as evidence on what is left of line_delay_us
  // (lineDelayLeftOver; evermap-vo-run --calibrate-line-delay). Not a user setting.
  bool gather_line_delay_evidence = false;
  // The angular velocities that evidence is judged with (LineDelayEvidenceOptions; none: each
  // frame's own). Not a user setting.
  std::shared_ptr<const AngularVelocities> line_delay_angular_velocity;

  Status validate() const;
  std::string describe() const;
  // The settings of this struct, with those of core/'s feature, matching, registration,
  // rotation and ORB options nested under features., matching., registration., rotation.
  // and orb.
  void declareOptions(OptionList& o) {
    o.add("keyframe_inlier_threshold", &keyframe_inlier_threshold, "inliers",
          "a frame with fewer inliers replaces the reference (at least registration's minimum)")
        .min(0);
    o.add("keyframe_inlier_fraction", &keyframe_inlier_fraction, "",
          "... or fewer than this fraction of the first frame's")
        .min(0)
        .below(1);
    o.add("keyframe_min_translation_m", &keyframe_min_translation_m, "m",
          "a new reference is a map keyframe after moving this far ...")
        .nonNegative();
    o.add("keyframe_min_rotation_rad", &keyframe_min_rotation_rad, "rad",
          "... or turning this much")
        .nonNegative();
    o.add("max_failed_frames", &max_failed_frames, "frames",
          "consecutive failures before the reference is replaced")
        .nonNegative();
    o.add("estimate_rotation", &estimate_rotation, "initial rotation from the top pyramid level");
    o.add("constant_velocity", &constant_velocity, "predict the last motion (else rotation only)");
    o.add("retry_previous_frame", &retry_previous_frame,
          "a frame failing against the reference tries the last registered frame");
    o.add("fast_motion_fraction", &fast_motion_fraction, "",
          "a frame failing both registrations is retried with bounds widened to this fraction "
          "of the predicted image motion (0: off)")
        .nonNegative();
    o.add("bridge_breaks", &bridge_breaks, "bridge a chain break with the motion prior");
    o.add("bridge.translation_sigma_m", &bridge.translation_sigma_m, "m",
          "motion prior's translation sigma per frame")
        .positive();
    o.add("bridge.rotation_sigma_rad", &bridge.rotation_sigma_rad, "rad",
          "motion prior's rotation sigma per frame")
        .positive();
    o.add("bridge.velocity_fraction", &bridge.velocity_fraction, "",
          "... plus this fraction of the predicted motion")
        .nonNegative();
    o.add("keyframe_descriptors", &keyframe_descriptors,
          "ORB descriptors on keyframes (for loop closure)");
    o.nest("features.", &features);
    o.nest("matching.", &matching);
    o.nest("registration.", &registration);
    o.nest("rotation.", &rotation);
    o.nest("orb.", &orb);
    o.add("self_calibrate", &self_calibrate,
          "estimate the stereo rig's disparity offset online and apply it");
    o.nest("self_calibration.", &self_calibration);
    o.add("line_delay_us", &line_delay_us, "us",
          "rolling shutter: the time between two rows' exposures (0: a global shutter)")
        .nonNegative();
  }

  static core::StereoFeatureExtractor::Options defaultFeatures();
  static core::RegistrationOptions defaultRegistration();
};

struct FrameResult {
  int64_t utime = 0;
  int64_t ref_utime = 0;  // the keyframe the motion is relative to
  VoStatus status = VoStatus::kBadInput;
  std::string message;            // one line; why, when status is not kOk
  bool keyframe_changed = false;  // this frame is now the reference keyframe
  // From the keyframe ref_utime to this frame: valid when status is kOk (identity for kNoData).
  core::SE3d ref_T_cur;
  core::Mat6 covariance = core::Mat6::Zero();  // right tangent (υ, ω) at ref_T_cur
  int num_corners = 0;                         // FAST corners detected
  int num_features = 0;                        // with a depth
  int num_matches = 0;
  int num_inliers = 0;
  double mean_reprojection_px = 0.0;
  // The keyframe features (ORB) when keyframe_changed and keyframe_descriptors.
  std::optional<core::KeyframeFeatures> keyframe;
  // kOk by the motion prior, not by a registration (a bridged break; covariance inflated).
  bool bridged = false;
  // kOk through the last registered frame after failing against the reference.
  bool via_previous = false;
  // kOk by the fast-motion retry (OdometryOptions::fast_motion_fraction): widened bounds.
  bool fast_motion = false;
  // Why, for a frame that did not register, in a few fixed words (for counting by kind):
  // "too few features", "too few consistent matches", "too few inliers after outlier
  // rejection", "reprojection error", "optimization failure", "stale reference",
  // "bad input"; with `bridged`, why the bridge was needed. Empty otherwise.
  std::string failure_kind;
  // The camera's disparity offset (pixels, cx_right - cx_left) and row slope (pixels per row)
  // after this frame and, on the frame self-calibration decided, its one-line summary
  // (calibration_changed: applied).
  double disparity_offset_px = 0.0;
  double disparity_row_slope = 0.0;
  std::string calibration_message;
  bool calibration_changed = false;

  bool ok() const { return status == VoStatus::kOk; }
};

// The registration options of the fast-motion retry: `registration` with the motion
// estimate's inlier bound raised to fraction · fx · (the rotation angle of prev_T_pred, the
// predicted motion over one frame) and its mean-error bound by the same factor; nullopt when
// that is not above the inlier bound (the frame did not fail for its motion) or fraction is 0.
std::optional<core::RegistrationOptions> fastMotionRegistration(
    const core::RegistrationOptions& registration, double fx, const core::SE3d& prev_T_pred,
    double fraction);

class StereoOdometry {
 public:
  // Refuses invalid options.
  static Expected<StereoOdometry> create(const core::StereoCamera& camera,
                                         const OdometryOptions& options);

  StereoOdometry(StereoOdometry&&) noexcept;
  StereoOdometry& operator=(StereoOdometry&&) noexcept;
  ~StereoOdometry();

  // One rectified stereo pair (CV_8UC1, the camera's size), in time order.
  FrameResult process(int64_t utime, const cv::Mat& left, const cv::Mat& right);
  // One RGB-D frame, undistorted to camera() (RgbdCamera::undistort: the gray image CV_8UC1,
  // depth CV_16UC1 in units of depth_scale_m, 0 = none), in time order; camera() must be the
  // RGB-D camera's equivalent stereo rig. A depth image with no valid pixel is a frame with
  // too few features (kInsufficientFeatures), and its message says so.
  FrameResult processRgbd(int64_t utime, const cv::Mat& gray, const cv::Mat& depth,
                          double depth_scale_m);

  // Forgets what the frames taught it but the camera and self-calibration (the reference, the
  // motion, the detector's adaptive threshold): the next usable frame starts anew (kNoData), as
  // with a new odometry of this camera.
  void reset();

  const core::StereoCamera& camera() const { return camera_; }
  const OdometryOptions& options() const { return options_; }
  bool hasReference() const { return has_ref_; }
  int fastThreshold() const;
  // Self-calibration's state (nullopt when it is off).
  std::optional<core::DisparityOffsetState> selfCalibration() const;
  // What the pairs say is left of the line delay (gather_line_delay_evidence only).
  std::optional<core::CurveEstimate> lineDelayLeftOver() const {
    return rolling_shutter_.leftOver();
  }

 private:
  StereoOdometry(const core::StereoCamera& camera, const OdometryOptions& options,
                 core::StereoFeatureExtractor extractor);

  // Everything after the features: `extract` fills cur_; `depth` (RGB-D only) explains a
  // frame without features.
  FrameResult track(int64_t utime, const std::function<Status()>& extract, const cv::Mat* depth);
  // The steps of track(). The frame's time order and its features (false: *result says why).
  bool extractFrame(int64_t utime, const std::function<Status()>& extract, FrameResult* result);
  // The motion prior: reference to current, predicted (and the rotation estimate's image kept).
  core::SE3d predictMotion(int64_t utime);
  // The last frame-to-frame motion carried over `dt_us` at its velocity (at most
  // kMaxVelocityExtrapolation times its own interval).
  core::SE3d scaledMotion(int64_t dt_us) const;
  static constexpr double kMaxVelocityExtrapolation = 10.0;
  void failTooFewFeatures(const cv::Mat* depth, const core::SE3d& ref_T_pred, FrameResult* result);
  // Too many failures in a row: the chain restarts at the current frame (bridged or not).
  void restartStaleReference(const core::SE3d& ref_T_pred, FrameResult* result);
  // The registration of the current frame and the motion from the reference to it.
  struct RegisteredMotion {
    core::RegistrationSummary summary;
    core::SE3d ref_T_cur;
    core::Mat6 covariance = core::Mat6::Zero();
    core::StereoMatchPair pair;  // reference and current matches, for self-calibration
    int64_t pair_group = 0;      // the reference's utime (pairs sharing it are one group)
    // A registration to the reference: its motion is the registration's own.
    void takeRegistration(const core::RegistrationSummary& registered) {
      summary = registered;
      ref_T_cur = registered.a_T_b;
      covariance = registered.covariance;
    }
    // The registration and motion of `other`; the self-calibration pair stays this one's.
    void takeMotionOf(const RegisteredMotion& other) {
      summary = other.summary;
      ref_T_cur = other.ref_T_cur;
      covariance = other.covariance;
    }
  };
  RegisteredMotion registerCurrent(const core::SE3d& ref_T_pred, FrameResult* result) const;
  // The current frame registered to the last frame that registered, the motion through it
  // chained to the reference (when it registers); `registration` as for registerTo.
  RegisteredMotion registerThroughPrevious(const core::SE3d& ref_T_pred,
                                           const core::RegistrationOptions* registration) const;
  // A registered motion: the result, the motion prior, and the reference or keyframe moved on.
  void takeMotion(const RegisteredMotion& motion, FrameResult* result);
  void failRegistration(const core::RegistrationSummary& reg, const core::SE3d& ref_T_pred,
                        FrameResult* result);
  // The current frame becomes the reference; a keyframe too when `keyframe`, else kf_T_cur
  // (the motion from the last keyframe to it) is kept for chaining.
  void makeCurrentTheReference(FrameResult* result, bool keyframe = true,
                               const core::UncertainPose& kf_T_cur = {});
  // Whether a new reference at kf_T_cur from the last keyframe is a keyframe.
  bool farEnoughForAKeyframe(const core::SE3d& kf_T_cur) const;
  // Matches `from` into the current frame in windows around the prediction from_T_pred
  // (from_T_cur) and registers: a = from, b = current.
  // With `pair`, a successful registration's matches go there (level-0 (u, v, d)).
  // `registration`: the options to register with (default: options_.registration).
  core::RegistrationSummary registerTo(
      const core::FeatureFrame& from, const core::SE3d& from_T_pred,
      core::StereoMatchPair* pair = nullptr,
      const core::RegistrationOptions* registration = nullptr) const;
  // The fast-motion retry of a frame that failed both registrations (m holds the failure).
  void retryFastMotion(const core::SE3d& ref_T_pred, RegisteredMotion* m, FrameResult* r) const;
  // Self-calibration: a registered pair to the tracker; a decided offset into the camera.
  void selfCalibrate(const core::StereoMatchPair& pair, int64_t group, FrameResult* result);
  // Adds `delta_px` to the camera's disparity offset and `delta_slope` to its row slope, and
  // to the features already extracted.
  void applyDisparityCorrection(double delta_px, double delta_slope);
  // The motion prior's covariance over `frames` predicted frames of `prev_T_cur`.
  core::Mat6 priorCovariance(const core::SE3d& prev_T_cur, int frames) const;
  // Bridges the break at the current frame by ref_T_pred (see the class comment).
  void bridge(const core::SE3d& ref_T_pred, FrameResult* result);

  core::StereoCamera camera_;
  OdometryOptions options_;
  core::StereoFeatureExtractor extractor_;
  core::OrbExtractor orb_;
  std::optional<core::DisparityOffsetTracker> offset_tracker_;  // self_calibrate only
  RollingShutterCorrector rolling_shutter_;
  // Buffers swapped, never copied: the reference, the last frame that registered to it, the
  // current frame.
  std::unique_ptr<core::FeatureFrame> ref_, prev_, cur_;
  bool has_ref_ = false;
  bool has_prev_ = false;  // prev_ holds a frame registered after the reference
  // The last frame-to-frame motion (the constant-velocity prediction).
  core::SE3d prev_T_cur_motion_;
  bool has_motion_ = false;
  int64_t prev_utime_ = -1;   // the frame ref_T_prev_ and prev_top_ are of (-1: none)
  int64_t frame_dt_us_ = 0;   // from it to the frame being tracked
  int64_t motion_dt_us_ = 0;  // the interval prev_T_cur_motion_ was measured over
  // The previous frame's top pyramid level, for the rotation estimate.
  cv::Mat prev_top_;
  // The last keyframe and the motion from it to the reference (identity when the reference
  // is the keyframe).
  int64_t kf_utime_ = 0;
  core::UncertainPose kf_T_ref_;
  // The motion from the reference to the previous frame, measured or predicted.
  core::SE3d ref_T_prev_;
  // The motion from the reference to prev_ (the last registered frame) with its covariance,
  // and the frames since then.
  core::SE3d ref_T_good_;
  core::Mat6 ref_T_good_cov_ = core::Mat6::Zero();
  int frames_since_good_ = 0;
  int failures_ = 0;
  // Inliers of the first frame registered against the reference (0: none yet).
  int first_inliers_ = 0;
};

}  // namespace evermap::vo
