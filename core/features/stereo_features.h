#pragma once
// The features of one rectified stereo frame, as FOVIS builds them (Huang et al. 2011,
// sections 3.1-3.3): a Gaussian pyramid of the left image, FAST corners on its lower levels
// (adaptive threshold, bucketing), a sub-pixel disparity for each corner from the right
// image, and the 3-D point and 9x9 patch descriptor of every corner that has a depth.
// Corners without a reliable depth are counted and dropped: frame registration needs a 3-D
// point on both sides of a match.

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
#include "core/features/stereo_depth.h"

namespace evermap::core {

struct StereoFeature {
  Keypoint keypoint;       // pixels of its level (integer: a FAST corner)
  Eigen::Vector2f uv;      // the same corner in level-0 pixels
  float disparity = 0.0f;  // level-0 pixels, > 0
  Eigen::Vector3d point;   // left camera frame, metres
  PatchDescriptor patch;   // at its level
};

struct FeatureFrame {
  int64_t utime = 0;
  ImagePyramid left;                   // kept for sub-pixel refinement, ORB and rotation
  std::vector<StereoFeature> features; // corners with a depth
  int num_corners = 0;                 // corners detected, with or without a depth
};

class StereoFeatureExtractor {
 public:
  struct Options {
    int feature_levels = 3;  // corners on pyramid levels [0, feature_levels)
    int pyramid_levels = 4;  // >= feature_levels; the top one serves rotation estimation
    FastDetector::Options fast;
    StereoDepth::Options stereo;

    Status validate() const;
  };

  // Refuses invalid options.
  static Expected<StereoFeatureExtractor> create(const Options& options);

  // Fills `frame` (reusing its buffers). Errors: an image that is empty, not 8-bit gray or
  // not of the camera's size (the message names which).
  Status extract(const StereoCamera& camera, int64_t utime, const cv::Mat& left,
                 const cv::Mat& right, FeatureFrame* frame);

  const FastDetector& detector() const { return detector_; }
  const Options& options() const { return options_; }

 private:
  explicit StereoFeatureExtractor(const Options& options)
      : options_(options), detector_(options.fast), depth_(options.stereo) {}

  Options options_;
  FastDetector detector_;
  StereoDepth depth_;
  ImagePyramid right_;
};

// Checks a stereo image against a camera: non-empty, CV_8UC1, camera size. `what` names the
// image in the message ("left image").
Status checkStereoImage(const StereoCamera& camera, const cv::Mat& image, const char* what);

}  // namespace evermap::core
