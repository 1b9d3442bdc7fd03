#pragma once
// Calibrations of ideal cameras: a pinhole without distortion, and the rectified stereo pair
// of two alike (what rectified images are taken with: the simulator's, a data set's already
// rectified ones).

#include "core/camera/calibration.h"

namespace evermap::core {

// A width x height pinhole without distortion, at the body origin.
inline CameraCalibration pinholeCamera(int width, int height, double fx, double fy, double cx,
                                       double cy) {
  return CameraCalibration{.width = width,
                           .height = height,
                           .fx = fx,
                           .fy = fy,
                           .cx = cx,
                           .cy = cy,
                           .distortion_model = DistortionModel::kNone,
                           .distortion = {},
                           .body_T_cam = SE3d()};
}

// Rectified images of `left`: the right camera alike, `baseline_m` along +x of the left.
inline StereoCalibration rectifiedPair(const CameraCalibration& left, double baseline_m) {
  StereoCalibration c;
  c.rectified = true;
  c.left = left;
  c.right = left;
  c.right.body_T_cam = left.body_T_cam * SE3d(SO3d(), Vec3(baseline_m, 0.0, 0.0));
  return c;
}

}  // namespace evermap::core
