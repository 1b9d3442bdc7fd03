#pragma once
// Depth of corners from a depth image registered to the gray image (an RGB-D camera), in
// place of stereo matching (stereo_depth.h): the depth is read, not searched for, and what
// must be refused is where the sensor is wrong or silent.
//
//  - no depth: the value is 0 (the Kinect's holes: too near, too far, dark or specular
//    surfaces, the projector's shadow), or out of [min_depth_m, max_depth_m];
//  - depth edges: a corner on an object's silhouette has a depth of the object or of the
//    background depending on a pixel, and the registered depth is shifted by up to a few
//    pixels there. A corner is refused when any pixel of the (2r+1)^2 window around it has no
//    depth, or the window's depths spread by more than max_relative_spread · z.
// The depth of an accepted corner is the centre pixel's (level 0, the corner's position
// rounded); it is returned as the equivalent stereo disparity of the camera (rgbd_camera.h).

#include <opencv2/core.hpp>

#include "core/camera/stereo_camera.h"
#include "core/common/expected.h"

namespace evermap {
class OptionList;  // core/common/option_fields.h
}  // namespace evermap

namespace evermap::core {

class RgbdDepth {
 public:
  struct Options {
    double min_depth_m = 0.4;  // the Kinect's near limit
    double max_depth_m = 5.0;  // beyond, σ_z > 3.5 cm and quantisation steps of ~10 cm
    int window_radius_px = 2;  // level-0 pixels around the corner checked for holes and edges
    double max_relative_spread = 0.05;  // max - min of the window, as a fraction of z

    Status validate() const;
    void declareOptions(OptionList& o);
  };

  // Contract: options.validate() passes (checked, aborts otherwise).
  explicit RgbdDepth(const Options& options);

  // The equivalent disparity (level-0 pixels) at level-0 position (u, v) of `depth`
  // (CV_16UC1, metres = value · scale_m); NaN where refused (see above).
  float disparity(const StereoCamera& camera, const cv::Mat& depth, double scale_m, float u,
                  float v) const;

  const Options& options() const { return options_; }

 private:
  Options options_;
};

}  // namespace evermap::core
