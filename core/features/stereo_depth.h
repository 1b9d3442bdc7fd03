#pragma once
// Depth of corners from a rectified stereo pair: for each corner of the left image, the best
// match along the same row of the right image (rectified: epipolar lines are rows), then a
// sub-pixel disparity.
//
//  1. Discrete search at the corner's pyramid level: sum of absolute differences of a
//     (2r+1)^2 window for every disparity in [0, max_disparity / 2^level].
//  2. Acceptance: the best mean absolute difference is below max_mean_abs_diff, and the best
//     cost is clearly below the best one outside +-1 px of it (uniqueness ratio, as in
//     Hirschmüller's SGM and OpenCV's StereoBM): repeated texture gives no depth rather
//     than a wrong one.
//  3. Sub-pixel: Lucas-Kanade along the row (core/features/patch_alignment.h), started at the
//     integer match; a refinement that moves more than max_refinement_px is rejected.
// The disparity is returned in level-0 pixels, as the camera model's:
// d0 = d_level * 2^level + camera.disparityCorrectionPx(v0): the offset cx_right - cx_left of
// the rectified images and the row slope's share at the corner's row v0
// (core/camera/stereo_camera.h; both 0 for most rigs). The camera is the only source of the
// correction: a calibration that carries it (STEREO_CALIB's right cx) corrects every depth.

#include <string>
#include <vector>

#include "core/camera/stereo_camera.h"
#include "core/common/expected.h"
#include "core/features/fast_detector.h"
#include "core/features/image_pyramid.h"

namespace evermap {
class OptionList;  // core/common/option_fields.h
}  // namespace evermap

namespace evermap::core {

class StereoDepth {
 public:
  struct Options {
    int window_radius_px = 3;         // SAD window (2r+1)^2 at the corner's level
    int max_disparity_px = 128;       // level 0; EuRoC (fx b = 50 px m): z >= 0.39 m
    double min_disparity_px = 0.5;    // level 0; smaller is too far to give a depth
    double max_mean_abs_diff = 16.0;  // gray levels per pixel at the best disparity
    double uniqueness_ratio = 0.9;    // best <= ratio * second best (outside +-1 px)
    bool subpixel = true;
    double max_refinement_px = 1.0;  // level pixels

    Status validate() const;
    void declareOptions(OptionList& o);
  };

  // Contract: options.validate() passes (checked, aborts otherwise).
  explicit StereoDepth(const Options& options);

  // Level-0 disparity (pixels) of every keypoint of `left` in `right` (pyramids of the same
  // size with at least as many levels as the keypoints use), corrected by the camera's
  // disparity offset; NaN when there is no reliable match.
  std::vector<float> compute(const StereoCamera& camera, const ImagePyramid& left,
                             const ImagePyramid& right,
                             const std::vector<Keypoint>& keypoints) const;

  // The same for one keypoint.
  float disparity(const StereoCamera& camera, const ImagePyramid& left, const ImagePyramid& right,
                  const Keypoint& k) const;

  const Options& options() const { return options_; }

 private:
  Options options_;
};

}  // namespace evermap::core
