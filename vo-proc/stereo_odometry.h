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
//   keyframes: the reference is kept while it yields at least keyframe_inlier_threshold
//              inliers, so drift does not grow while the camera hovers; below that, the
//              current frame becomes the reference (and a keyframe for the map, with ORB
//              descriptors).
//
// Failures never throw and never abort: each frame gets a status (values of vo_delta_t).
//  - kBadInput: an image is empty, not gray or not the camera's size. Nothing changes.
//  - kInsufficientFeatures: too few features with depth (dark, blank wall). The frame is
//    never made a reference. The first usable frame after more than max_failed_frames
//    failures becomes the reference without a registration (kNoData, the chain restarts):
//    after a gap the predicted motion is stale, and a search from it aliases on repeated
//    texture.
//  - kInsufficientInliers / kOptimizationFailure / kReprojectionError: the frame does not
//    register to the reference (occlusion, fast motion). The reference is kept for up to
//    max_failed_frames failures in a row (a passer-by); after that the next frame with enough
//    features becomes the reference (keyframe_changed, ref_utime = its own utime), which
//    breaks the chain of motions: the mapper bridges the gap (wheel odometry), VO restarts
//    from there.
//
// Not thread-safe; one instance per camera stream.

#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include <opencv2/core.hpp>

#include "core/camera/stereo_camera.h"
#include "core/common/expected.h"
#include "core/features/orb_descriptor.h"
#include "core/features/stereo_features.h"
#include "core/geometry/se3.h"
#include "core/registration/frame_registration.h"
#include "core/registration/keyframe_features.h"
#include "core/registration/rotation_estimation.h"
#include "core/registration/window_matcher.h"

namespace evermap::vo {

// Values equal vo_delta_t::STATUS_*.
enum class VoStatus : int8_t {
  kOk = 0,
  kNoData = 1,                // the first usable frame: it becomes the reference
  kInsufficientFeatures = 2,  // dark, blank wall
  kInsufficientInliers = 3,   // occlusion, fast motion
  kOptimizationFailure = 4,
  kReprojectionError = 5,
  kBadInput = 6,              // wrong size, empty image, no valid calibration
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
  // Consecutive failures against the reference before it is replaced.
  int max_failed_frames = 2;
  // ORB descriptors of keyframes (for loop closure); off saves their cost.
  bool keyframe_descriptors = true;
  core::OrbExtractor::Options orb;

  Status validate() const;
  std::string describe() const;

  static core::StereoFeatureExtractor::Options defaultFeatures();
  static core::RegistrationOptions defaultRegistration();
};

struct FrameResult {
  int64_t utime = 0;
  int64_t ref_utime = 0;  // the reference the motion is relative to
  VoStatus status = VoStatus::kBadInput;
  std::string message;    // one line; why, when status is not kOk
  bool keyframe_changed = false;  // this frame is now the reference
  core::SE3d ref_T_cur;           // valid when status is kOk (identity for kNoData)
  core::Mat6 covariance = core::Mat6::Zero();  // right tangent (υ, ω) at ref_T_cur
  int num_corners = 0;   // FAST corners detected
  int num_features = 0;  // with a depth
  int num_matches = 0;
  int num_inliers = 0;
  double mean_reprojection_px = 0.0;
  // The keyframe features (ORB) when keyframe_changed and keyframe_descriptors.
  std::optional<core::KeyframeFeatures> keyframe;

  bool ok() const { return status == VoStatus::kOk; }
};

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

  // Forgets the reference: the next usable frame starts anew (kNoData).
  void reset();

  const core::StereoCamera& camera() const { return camera_; }
  const OdometryOptions& options() const { return options_; }
  bool hasReference() const { return has_ref_; }
  int fastThreshold() const;

 private:
  StereoOdometry(const core::StereoCamera& camera, const OdometryOptions& options,
                 core::StereoFeatureExtractor extractor);

  void makeCurrentTheReference(FrameResult* result);

  core::StereoCamera camera_;
  OdometryOptions options_;
  core::StereoFeatureExtractor extractor_;
  core::OrbExtractor orb_;
  // Buffers swapped, never copied: the reference, the current frame.
  std::unique_ptr<core::FeatureFrame> ref_, cur_;
  bool has_ref_ = false;
  // The previous frame's top pyramid level, for the rotation estimate.
  cv::Mat prev_top_;
  // The last known motion from the reference to the previous frame (the prediction).
  core::SE3d ref_T_prev_;
  int failures_ = 0;
  // Inliers of the first frame registered against the reference (0: none yet).
  int first_inliers_ = 0;
};

}  // namespace evermap::vo
