#include "core/camera/stereo_rectifier.h"

#include <cmath>
#include <string>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <opencv2/imgproc.hpp>

#include "core/common/option_fields.h"

namespace evermap::core {
namespace {

cv::Mat cameraMatrix(const CameraCalibration& c) {
  return (cv::Mat_<double>(3, 3) << c.fx, 0.0, c.cx, 0.0, c.fy, c.cy, 0.0, 0.0, 1.0);
}

cv::Mat distortionVector(const CameraCalibration& c) {
  if (c.distortion.empty()) return cv::Mat();  // OpenCV: no distortion
  cv::Mat d(1, static_cast<int>(c.distortion.size()), CV_64F);
  for (size_t i = 0; i < c.distortion.size(); ++i) {
    d.at<double>(0, static_cast<int>(i)) = c.distortion[i];
  }
  return d;
}

Status checkImage(const cv::Mat& image, const char* which, const CameraCalibration& raw) {
  if (image.empty()) return makeError("rectify: the ", which, " image is empty");
  if (image.type() != CV_8UC1) {
    return makeError("rectify: the ", which, " image is not 8-bit gray (OpenCV type ", image.type(),
                     ")");
  }
  if (image.cols != raw.width || image.rows != raw.height) {
    return makeError("rectify: the ", which, " image is ", image.cols, "x", image.rows,
                     ", the calibration says ", raw.width, "x", raw.height);
  }
  return Ok{};
}

}  // namespace

void StereoRectifier::Options::declareOptions(OptionList& o) {
  o.add("alpha", &alpha, "",
        "free scaling: 0 no black borders, 1 every source pixel in view (cv::stereoRectify)")
      .in(0, 1);
  o.add("bilinear", &bilinear, "bilinear remap (else nearest neighbour)");
}

Status StereoRectifier::Options::validate() const { return checkOptionRanges(*this, "rectifier."); }

Expected<StereoRectifier> StereoRectifier::create(const StereoCalibration& raw,
                                                  const Options& options) {
  if (Status s = options.validate(); !s) return s.error();
  if (raw.rectified) {
    return makeError("rectifier: the calibration says the images are already rectified");
  }
  if (Status s = raw.validate(); !s) return s.error();

  std::array<cv::Mat, 2> K = {cameraMatrix(raw.left), cameraMatrix(raw.right)};
  std::array<cv::Mat, 2> D = {distortionVector(raw.left), distortionVector(raw.right)};
  // cv::stereoRectify takes the motion of the second camera: p_right = R p_left + T.
  const SE3d r_T_l = raw.right_T_left();
  cv::Mat R, T;
  cv::eigen2cv(Eigen::Matrix3d(r_T_l.rotationMatrix()), R);
  cv::eigen2cv(Eigen::Vector3d(r_T_l.translation()), T);
  const cv::Size size(raw.left.width, raw.left.height);
  std::array<cv::Mat, 2> Rr, P;
  cv::Mat Q;
  cv::stereoRectify(K[0], D[0], K[1], D[1], size, R, T, Rr[0], Rr[1], P[0], P[1], Q,
                    cv::CALIB_ZERO_DISPARITY, options.alpha, size);
  if (std::abs(P[1].at<double>(1, 3)) > 1e-9 * std::abs(P[1].at<double>(0, 3))) {
    return makeError(
        "rectifier: the rig is vertical (baseline along y); only horizontal "
        "stereo is supported");
  }
  // P_right = [f 0 cx -f b; 0 f cy 0; 0 0 1 0]: b = -P_right(0,3) / f.
  const double f = P[0].at<double>(0, 0);
  const double baseline = -P[1].at<double>(0, 3) / P[1].at<double>(0, 0);
  auto camera = StereoCamera::create(f, P[0].at<double>(1, 1), P[0].at<double>(0, 2),
                                     P[0].at<double>(1, 2), baseline, size.width, size.height);
  if (!camera) {
    return makeError("rectifier: rectified ", camera.error().message,
                     baseline < 0.0 ? " (left and right cameras swapped?)" : "");
  }

  StereoRectifier r(raw, *camera);
  r.bilinear_ = options.bilinear;
  for (int s = 0; s < 2; ++s) {
    r.K_[s] = K[s];
    r.D_[s] = D[s];
    r.R_[s] = Rr[s];
    r.P_[s] = P[s];
    cv::initUndistortRectifyMap(K[s], D[s], Rr[s], P[s], size, CV_16SC2, r.map1_[s], r.map2_[s]);
  }

  // Rectified frames: p_rect = rect_R_raw p_raw, so body_T_rect = body_T_raw * (rect_R_raw)ᵀ;
  // the right rectified camera is the left one moved by +b along x.
  Eigen::Matrix3d rect0_R_cam0;
  cv::cv2eigen(Rr[0], rect0_R_cam0);
  StereoCalibration& rc = r.rectified_;
  rc.rectified = true;
  for (CameraCalibration* c : {&rc.left, &rc.right}) {
    c->width = size.width;
    c->height = size.height;
    c->fx = camera->fx();
    c->fy = camera->fy();
    c->cx = camera->cx();
    c->cy = camera->cy();
    c->distortion_model = DistortionModel::kNone;
    c->distortion.clear();
  }
  rc.left.body_T_cam =
      raw.left.body_T_cam * SE3d(SO3d::fromMatrix(rect0_R_cam0.transpose()), Vec3::Zero());
  rc.right.body_T_cam = rc.left.body_T_cam * SE3d(SO3d(), Vec3(baseline, 0.0, 0.0));
  return r;
}

Expected<RectifiedPair> StereoRectifier::rectify(const cv::Mat& left_raw,
                                                 const cv::Mat& right_raw) const {
  if (Status s = checkImage(left_raw, "left", raw_.left); !s) return s.error();
  if (Status s = checkImage(right_raw, "right", raw_.right); !s) return s.error();
  RectifiedPair out;
  const int interpolation = bilinear_ ? cv::INTER_LINEAR : cv::INTER_NEAREST;
  cv::remap(left_raw, out.left, map1_[0], map2_[0], interpolation, cv::BORDER_CONSTANT);
  cv::remap(right_raw, out.right, map1_[1], map2_[1], interpolation, cv::BORDER_CONSTANT);
  return out;
}

Eigen::Vector2d StereoRectifier::rectifyPoint(Side side, const Eigen::Vector2d& raw_px) const {
  const int s = static_cast<int>(side);
  std::vector<cv::Point2d> in = {cv::Point2d(raw_px.x(), raw_px.y())}, out;
  cv::undistortPoints(in, out, K_[s], D_[s], R_[s], P_[s]);
  return Eigen::Vector2d(out[0].x, out[0].y);
}

Expected<SE3d> rectifiedLeftBodyTCamera(const StereoCalibration& calibration,
                                        const StereoRectifier::Options& options) {
  if (calibration.rectified) {
    if (Status s = calibration.validate(); !s) return s.error();
    return calibration.left.body_T_cam;
  }
  auto rectifier = StereoRectifier::create(calibration, options);
  if (!rectifier) return rectifier.error();
  return rectifier->rectifiedCalibration().left.body_T_cam;
}

}  // namespace evermap::core
