#pragma once
// Raw calibration of one camera and of a stereo rig, as read from a data set and as carried by
// the LCM messages camera_calib_t / stereo_calib_t (one field here per message field).
//
// Pixel model of one camera (OpenCV's): normalised coordinates (x/z, y/z) are distorted by the
// radial-tangential model k1 k2 p1 p2 [k3] (Brown-Conrady, as EuRoC's "radial-tangential" and
// OpenCV's distortion vector) and then mapped by fx, fy, cx, cy.
// `body_T_cam` maps points in the camera frame to the body (IMU) frame; the stereo extrinsics
// follow: right_T_left = body_T_right⁻¹ · body_T_left (EuRoC's cam1_T_cam0).

#include <cstdint>
#include <string>
#include <vector>

#include "core/camera/stereo_camera.h"
#include "core/common/expected.h"
#include "core/geometry/se3.h"

namespace evermap::core {

// Values equal camera_calib_t::DISTORTION_*.
enum class DistortionModel : int8_t {
  kNone = 0,
  kRadTan = 1,  // k1 k2 p1 p2, optionally k3
};

struct CameraCalibration {
  int width = 0;              // pixels
  int height = 0;             // pixels
  double fx = 0.0, fy = 0.0;  // focal lengths, pixels
  double cx = 0.0, cy = 0.0;  // principal point, pixels
  DistortionModel distortion_model = DistortionModel::kNone;
  std::vector<double> distortion;  // kRadTan: k1 k2 p1 p2 [k3]; kNone: empty
  SE3d body_T_cam;

  // Refuses a non-positive or non-finite focal length or size, a principal point outside the
  // image, a wrong number of distortion coefficients. The message starts with `what`.
  Status validate(const std::string& what) const;
};

struct StereoCalibration {
  // true: both cameras are the rectified pinholes of the images (no distortion, same fx, fy,
  // cy, right camera translated along +x of the left only). Their cx may differ, by at most a
  // quarter of the width: right.cx - left.cx is the rig's disparity offset
  // (StereoCamera::disparityOffsetPx; KITTI's clip: +0.8 px, docs/vo.md).
  bool rectified = false;
  CameraCalibration left;
  CameraCalibration right;

  // Maps points in the left camera frame to the right camera frame.
  SE3d right_T_left() const { return right.body_T_cam.inverse() * left.body_T_cam; }
  // Both cameras valid, same image size, a positive finite baseline; when rectified, also the
  // rectified-pair invariants above. `what` names the source in the message ("cam0/cam1").
  Status validate(const std::string& what = "stereo calibration") const;
};

// The StereoCamera of a calibration whose images are already rectified (rectified == true),
// its disparity offset right.cx - left.cx; an error when the calibration is invalid or not
// rectified.
Expected<StereoCamera> rectifiedStereoCamera(const StereoCalibration& calibration);

// The same rectified calibration with the right camera's cx = left.cx + offset_px: how a
// disparity offset measured on the images (evermap-stereo-check --self-offset) becomes part of
// the calibration (evermap-kitti2lcm --disparity-offset). An error when the calibration is not
// rectified (a raw pair's rectification decides the rectified cx itself) or the result is
// invalid (the offset beyond a quarter of the width).
Expected<StereoCalibration> withDisparityOffset(const StereoCalibration& calibration,
                                                double offset_px);

}  // namespace evermap::core
