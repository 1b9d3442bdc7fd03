#pragma once
// An initial estimate of the rotation between two consecutive frames from their small,
// blurred images alone (FOVIS's initial rotation estimate, Huang et al. 2011 section 3.3):
// the camera motion between frames is dominated by rotation, and a pure rotation R maps the
// image by the homography K R K⁻¹. R (and a brightness offset) is found by Gauss-Newton on
// the photometric error over the top pyramid level, in the inverse-compositional form of
// Baker & Matthews (IJCV 2004, section 3), whose normal equations are computed once.
//
// With the rotation, the matching window is centred where features will be after a fast turn,
// so a small window suffices.

#include <optional>

#include <opencv2/core.hpp>

#include "core/camera/stereo_camera.h"
#include "core/geometry/se3.h"

namespace evermap {
class OptionList;  // core/common/option_fields.h
}  // namespace evermap

namespace evermap::core {

struct RotationEstimateOptions {
  int max_iterations = 15;
  double converged_rad = 1e-4;
  // A result turning more than this between two frames is refused (radians).
  double max_angle_rad = 0.6;
  // Pixels of the level left out around the border (gradients, warp).
  int border_px = 2;
  // Pixels whose gradient |gx| + |gy| (gray levels per pixel) is below this are left out.
  float min_gradient = 3.0f;

  void declareOptions(OptionList& o);
};

// b_R_a for two images of the same pyramid level `level` of cameras with the intrinsics of
// `camera` (level 0), so that a pixel x_a of image a is seen at K R K⁻¹ x_a in image b;
// nullopt when the images differ in size, have no texture, or the estimate diverges. The
// search starts from `initial` (a predicted b_R_a): the photometric error has a basin of a
// few pixels at the top level, which a fast turn over a long interval can leave.
std::optional<SO3d> estimateRotation(const cv::Mat& image_a, const cv::Mat& image_b,
                                     const StereoCamera& camera, int level,
                                     const RotationEstimateOptions& options,
                                     const SO3d& initial = SO3d());

}  // namespace evermap::core
