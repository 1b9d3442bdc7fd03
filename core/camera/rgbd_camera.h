#pragma once
// An RGB-D camera (a Kinect: a gray image and a depth image registered to it) as the rest of
// evermap measures with it: an *equivalent rectified stereo rig* (StereoCamera) whose
// disparity noise gives the Kinect's depth noise, so feature frames, registration, keyframes
// and everything downstream are the same code for both camera kinds (DESIGN.md section 4:
// "only the depth of a feature comes from a different place").
//
// Why that is exact, not an approximation: a stereo point's depth error is, to first order,
//   σ_z = z² σ_d / (f_x b)                                   (stereo_camera.h, Matthies & Shafer)
// and the Kinect's (itself a structured-light triangulation) is
//   σ_z = k z²,  k = 1.425e-3 m⁻¹                             (Khoshelham & Elberink, "Accuracy
//        and resolution of Kinect depth data for indoor mapping applications", Sensors 12(2),
//        2012: the random error grows with the square of the distance, ~4 cm at 5 m).
// With the equivalent baseline b = σ_d / (k f_x), where σ_d is the disparity noise the
// registration assumes (RegistrationOptions::disparity_sigma_px), the two agree at every
// depth: the clique's consistency test and the motion estimate's whitening
// (frame_registration.cpp, motion_estimation.cpp) use the Kinect's model without a change,
// and so does loop closure on the keyframes (which carry this camera).
// A feature at depth z gets the disparity d = f_x b / z.
//
// Distortion: a calibration with radial-tangential distortion (TUM freiburg1/2) is undistorted
// to the same pinhole (fx, fy, cx, cy): the gray image bilinearly, the depth image by nearest
// neighbour (interpolating depth across an edge invents points in between).

#include <string>

#include <opencv2/core.hpp>

#include "core/camera/calibration.h"
#include "core/camera/stereo_camera.h"
#include "core/common/expected.h"

namespace evermap {
class OptionList;  // core/common/option_fields.h
}  // namespace evermap

namespace evermap::core {

class RgbdCamera {
 public:
  struct Options {
    // σ_z = depth_noise_per_m2 · z² (metres), Khoshelham & Elberink 2012.
    double depth_noise_per_m2 = 1.425e-3;
    // The disparity noise (pixels) the registration assumes; the equivalent baseline follows.
    double disparity_sigma_px = 0.2;

    Status validate() const;
    void declareOptions(OptionList& o);
  };

  // Refuses an invalid calibration (CameraCalibration::validate) or options.
  static Expected<RgbdCamera> create(const CameraCalibration& calibration, const Options& options);

  // The rig of the undistorted images: fx, fy, cx, cy, size of the calibration, baseline
  // disparity_sigma_px / (depth_noise_per_m2 · fx).
  const StereoCamera& stereo() const { return stereo_; }
  const CameraCalibration& calibration() const { return calibration_; }
  const Options& options() const { return options_; }
  bool distorted() const { return !map_x_.empty(); }

  // σ_z (metres) of a depth z (metres).
  double depthSigmaM(double z_m) const { return options_.depth_noise_per_m2 * z_m * z_m; }

  // The images undistorted to stereo()'s pinhole (copies of the input when the calibration
  // has no distortion). Errors: gray not CV_8UC1 or depth not CV_16UC1, or either not of the
  // calibration's size (the message names which and the sizes).
  Status undistort(const cv::Mat& gray, const cv::Mat& depth, cv::Mat* gray_out,
                   cv::Mat* depth_out) const;

  // "rgbd fx=517.3 ... b_equiv=0.271m, depth noise 1.425e-3 z^2".
  std::string describe() const;

 private:
  RgbdCamera(const CameraCalibration& calibration, const Options& options,
             const StereoCamera& stereo)
      : calibration_(calibration), options_(options), stereo_(stereo) {}

  CameraCalibration calibration_;
  Options options_;
  StereoCamera stereo_;
  cv::Mat map_x_, map_y_;  // undistortion maps (CV_32FC1); empty without distortion
};

}  // namespace evermap::core
