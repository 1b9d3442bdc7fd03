#pragma once
// Rectification of a raw (distorted, unaligned) stereo pair into the rectified pinhole pair a
// StereoCamera describes: Bouguet's method as implemented by cv::stereoRectify (both image
// planes rotated half-way onto a common plane parallel to the baseline, zero disparity at
// infinity: the rectified principal points coincide), then one remap per image through the
// tables of cv::initUndistortRectifyMap.
//
// The rectifier is immutable after create(); rectify() may be called from several threads.

#include <array>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "core/camera/calibration.h"
#include "core/camera/stereo_camera.h"
#include "core/common/expected.h"

namespace evermap {
class OptionList;  // core/common/option_fields.h
}  // namespace evermap

namespace evermap::core {

struct RectifiedPair {
  cv::Mat left;  // CV_8UC1, camera().width() x camera().height()
  cv::Mat right;
};

class StereoRectifier {
 public:
  struct Options {
    // cv::stereoRectify's free scaling: 0 zooms in until every rectified pixel has a source
    // pixel (no black borders, the default: features never sit on an invalid border);
    // 1 keeps every source pixel in view (black borders); values between interpolate.
    double alpha = 0.0;
    // Bilinear interpolation of the remap; nearest neighbour would add up to 0.5 px of
    // quantisation to every feature.
    bool bilinear = true;

    Status validate() const;
    void declareOptions(OptionList& o);
  };

  enum class Side { kLeft = 0, kRight = 1 };

  // Refuses an invalid or already rectified calibration, and one whose rectified baseline is
  // not positive (left and right swapped).
  static Expected<StereoRectifier> create(const StereoCalibration& raw, const Options& options);
  static Expected<StereoRectifier> create(const StereoCalibration& raw) {
    return create(raw, Options{});
  }

  // The rectified pinhole pair.
  const StereoCamera& camera() const { return camera_; }
  // The calibration of the rectified images (rectified = true, no distortion); body_T_cam of
  // each camera is the rotated (rectified) camera frame.
  const StereoCalibration& rectifiedCalibration() const { return rectified_; }
  const StereoCalibration& rawCalibration() const { return raw_; }

  // Rectifies one raw pair; both images must be CV_8UC1 of the calibrated size.
  Expected<RectifiedPair> rectify(const cv::Mat& left_raw, const cv::Mat& right_raw) const;

  // The rectified pixel of a raw pixel of one camera (undistort, rotate, project): for
  // features detected on raw images.
  Eigen::Vector2d rectifyPoint(Side side, const Eigen::Vector2d& raw_px) const;

 private:
  StereoRectifier(const StereoCalibration& raw, const StereoCamera& camera)
      : raw_(raw), camera_(camera) {}

  StereoCalibration raw_;
  StereoCalibration rectified_;
  StereoCamera camera_;
  bool bilinear_ = true;
  // Per side: raw camera matrix and distortion, rect_R_raw, rectified projection (3x4).
  std::array<cv::Mat, 2> K_, D_, R_, P_;
  // Per side: fixed-point remap tables (CV_16SC2 + CV_16UC1).
  std::array<cv::Mat, 2> map1_, map2_;
};

// body_T_cam of the left camera the images are (or, raw, will be) rectified to: the frame VO
// motions are expressed in. Errors: an invalid calibration, one that does not rectify.
Expected<SE3d> rectifiedLeftBodyTCamera(const StereoCalibration& calibration,
                                        const StereoRectifier::Options& options = {});

}  // namespace evermap::core
