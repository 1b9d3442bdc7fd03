#include "core/camera/rgbd_camera.h"

#include <cmath>
#include <sstream>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "core/common/option_fields.h"

namespace evermap::core {

void RgbdCamera::Options::declareOptions(OptionList& o) {
  o.add("depth_noise_per_m2", &depth_noise_per_m2, "1/m",
        "depth noise sigma_z = this * z^2 (Khoshelham & Elberink 2012)")
      .positive();
  o.add("disparity_sigma_px", &disparity_sigma_px, "px",
        "disparity noise the registration assumes (sets the equivalent baseline)")
      .positive();
}

Status RgbdCamera::Options::validate() const { return checkOptionRanges(*this, "rgbd."); }

Expected<RgbdCamera> RgbdCamera::create(const CameraCalibration& c, const Options& options) {
  if (Status s = options.validate(); !s) return s.error();
  if (Status s = c.validate("rgbd camera"); !s) return s.error();
  const double baseline_m = options.disparity_sigma_px / (options.depth_noise_per_m2 * c.fx);
  auto stereo = StereoCamera::create(c.fx, c.fy, c.cx, c.cy, baseline_m, c.width, c.height);
  if (!stereo) return stereo.error();
  RgbdCamera camera(c, options, *stereo);
  if (c.distortion_model == DistortionModel::kRadTan && !c.distortion.empty()) {
    bool any = false;
    for (double k : c.distortion) any = any || k != 0.0;
    if (any) {
      const cv::Matx33d K(c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1);
      cv::initUndistortRectifyMap(K, c.distortion, cv::Matx33d::eye(), K,
                                  cv::Size(c.width, c.height), CV_32FC1, camera.map_x_,
                                  camera.map_y_);
    }
  }
  return camera;
}

Status RgbdCamera::undistort(const cv::Mat& gray, const cv::Mat& depth, cv::Mat* gray_out,
                             cv::Mat* depth_out) const {
  const auto check = [this](const cv::Mat& m, int type, const char* what) -> Status {
    if (m.empty() || m.type() != type) {
      return makeError(what, ": ", m.empty() ? "empty" : "wrong pixel type",
                       type == CV_16UC1 ? " (need 16-bit one-channel)" : " (need 8-bit gray)");
    }
    if (m.cols != calibration_.width || m.rows != calibration_.height) {
      return makeError(what, ": ", m.cols, "x", m.rows, " but the camera is ", calibration_.width,
                       "x", calibration_.height);
    }
    return Ok{};
  };
  if (Status s = check(gray, CV_8UC1, "gray image"); !s) return s;
  if (Status s = check(depth, CV_16UC1, "depth image"); !s) return s;
  if (!distorted()) {
    gray.copyTo(*gray_out);
    depth.copyTo(*depth_out);
    return Ok{};
  }
  cv::remap(gray, *gray_out, map_x_, map_y_, cv::INTER_LINEAR, cv::BORDER_CONSTANT, 0);
  // Outside the image: 0, no depth.
  cv::remap(depth, *depth_out, map_x_, map_y_, cv::INTER_NEAREST, cv::BORDER_CONSTANT, 0);
  return Ok{};
}

std::string RgbdCamera::describe() const {
  std::ostringstream s;
  s << "rgbd " << stereo_.describe() << " (equivalent baseline), depth noise "
    << options_.depth_noise_per_m2 << " z^2" << (distorted() ? ", undistorted" : "");
  return s.str();
}

}  // namespace evermap::core
