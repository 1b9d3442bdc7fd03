#pragma once
// The features of one rectified stereo frame, as FOVIS builds them (Huang et al. 2011,
// sections 3.1-3.3): a Gaussian pyramid of the left image, FAST corners on its lower levels
// (adaptive threshold, bucketing), a sub-pixel disparity for each corner from the right
// image, and the 3-D point and 9x9 patch descriptor of every corner that has a depth.
// Corners without a reliable depth are counted and dropped: frame registration needs a 3-D
// point on both sides of a match.
// The same for an RGB-D frame (extractRgbd): the depth of each corner is read from the depth
// image (rgbd_depth.h) instead of matched in a right image, and becomes the disparity of the
// camera's equivalent stereo rig (core/camera/rgbd_camera.h); everything else is identical.

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "core/camera/stereo_camera.h"
#include "core/common/expected.h"
#include "core/features/fast_detector.h"
#include "core/features/image_pyramid.h"
#include "core/features/patch_descriptor.h"
#include "core/features/rgbd_depth.h"
#include "core/features/stereo_depth.h"

namespace evermap {
class OptionList;  // core/common/option_fields.h
}  // namespace evermap

namespace evermap::core {

struct StereoFeature {
  Keypoint keypoint;       // pixels of its level (integer: a FAST corner)
  Eigen::Vector2f uv;      // the same corner in level-0 pixels
  float disparity = 0.0f;  // level-0 pixels, > 0: the camera model's (its offset applied)
  Eigen::Vector3d point;   // left camera frame, metres
  PatchDescriptor patch;   // at its level

  // The corner in level-0 pixels as detected: uv until a correction moves the feature
  // (a rolling shutter's, vo-proc/rolling_shutter_corrector.h), where the image has it.
  Eigen::Vector2f cornerUv() const {
    const float s = ImagePyramid::scale(keypoint.level);
    return Eigen::Vector2f(keypoint.u * s, keypoint.v * s);
  }
};

struct FeatureFrame {
  int64_t utime = 0;
  ImagePyramid left;                    // kept for sub-pixel refinement, ORB and rotation
  std::vector<StereoFeature> features;  // corners with a depth
  int num_corners = 0;                  // corners detected, with or without a depth
  // The camera's angular velocity when the frame was taken (rad/s, its own frame), set by an
  // odometry that corrects a rolling shutter (core/camera/rolling_shutter.h); zero otherwise.
  Eigen::Vector3d omega = Eigen::Vector3d::Zero();
};

class StereoFeatureExtractor {
 public:
  struct Options {
    int feature_levels = 3;  // corners on pyramid levels [0, feature_levels)
    int pyramid_levels = 4;  // >= feature_levels; the top one serves rotation estimation
    FastDetector::Options fast;
    StereoDepth::Options stereo;
    RgbdDepth::Options rgbd;  // RGB-D frames only

    Status validate() const;
    void declareOptions(OptionList& o);
  };

  // Refuses invalid options.
  static Expected<StereoFeatureExtractor> create(const Options& options);

  // Fills `frame` (reusing its buffers). Errors: an image that is empty, not 8-bit gray or
  // not of the camera's size (the message names which).
  Status extract(const StereoCamera& camera, int64_t utime, const cv::Mat& left,
                 const cv::Mat& right, FeatureFrame* frame);

  // An RGB-D frame: `gray` (CV_8UC1) and `depth` (CV_16UC1, metres = value · depth_scale_m),
  // both undistorted to `camera` (RgbdCamera::undistort) and of its size. Errors as extract().
  Status extractRgbd(const StereoCamera& camera, int64_t utime, const cv::Mat& gray,
                     const cv::Mat& depth, double depth_scale_m, FeatureFrame* frame);

  const FastDetector& detector() const { return detector_; }
  const Options& options() const { return options_; }

 private:
  explicit StereoFeatureExtractor(const Options& options)
      : options_(options),
        detector_(options.fast),
        depth_(options.stereo),
        rgbd_depth_(options.rgbd) {}

  // Pyramid, corners and, for each corner with a depth (`disparity` of its level-0 position,
  // NaN for none), the feature.
  template <typename Disparity>
  Status extractWith(const StereoCamera& camera, int64_t utime, const cv::Mat& left,
                     FeatureFrame* frame, Disparity disparity);

  Options options_;
  FastDetector detector_;
  StereoDepth depth_;
  RgbdDepth rgbd_depth_;
  ImagePyramid right_;
};

// Checks a stereo image against a camera: non-empty, CV_8UC1, camera size. `what` names the
// image in the message ("left image").
Status checkStereoImage(const StereoCamera& camera, const cv::Mat& image, const char* what);

}  // namespace evermap::core
