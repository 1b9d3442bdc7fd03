#pragma once
// A rectified stereo pair of pinhole cameras: the model every evermap component measures with.
//
// Invariant (checked by validate()/create()): fx, fy > 0 and finite; baseline_m > 0 and finite;
// width, height > 0; the principal point (cx, cy) lies inside the image [0, width) x [0, height);
// |disparity_offset_px| <= width / 4 and finite; |disparity_row_slope| x height <= width / 4 and
// finite.
// Both cameras share fx, fy, cy and the image size; the right camera sits at +baseline_m along
// the x axis of the left camera frame, with the same orientation (rectified images: the
// epipolar lines are image rows). The right camera's principal point is at
// cx_right = cx + disparity_offset_px (0 for most rigs; KITTI's clip: +0.8 px, docs/vo.md).
// Points are in the left camera frame (x right, y down, z forward), metres; pixels (u, v) are
// in the left image, u along rows.
//
//   u = fx x / z + cx,   v = fy y / z + cy,   d = fx b / z,
//   d = d_measured + disparity_offset_px + disparity_row_slope (v - cy),
//   d_measured = u_left - u_right (in the images).
//
// The row slope (pixels of disparity per image row, 0 for most rigs) is a rectification
// residual that shifts the right image's rows in proportion to their distance from cy (a
// skew of the right camera against the left's); the KITTI clip's images say +0.004
// (docs/vo.md, "Self-calibration of the disparity offset").
//
// Every disparity this class takes or returns is d, the one that gives the depth; only a
// matcher that compares the two images (StereoDepth) sees d_measured and adds the offset.
//
// Back-projection and its first-order covariance Σ_p = J Σ_uvd Jᵀ, J = ∂p/∂(u, v, d): the 3-D
// Gaussian error model of Matthies & Shafer, "Error modeling in stereo navigation", IEEE J.
// Robotics and Automation 3(3), 1987.

#include <optional>
#include <string>

#include <Eigen/Core>

#include "core/common/expected.h"

namespace evermap::core {

class StereoCamera {
 public:
  using Vec3 = Eigen::Vector3d;
  using Mat3 = Eigen::Matrix3d;

  // Refuses an inconsistent model with an error naming the field and its value.
  // disparity_offset_px = cx_right - cx_left of the rectified images (see above).
  static Expected<StereoCamera> create(double fx, double fy, double cx, double cy,
                                       double baseline_m, int width, int height,
                                       double disparity_offset_px = 0.0,
                                       double disparity_row_slope = 0.0);

  double fx() const { return fx_; }
  double fy() const { return fy_; }
  double cx() const { return cx_; }
  double cy() const { return cy_; }
  double baselineM() const { return baseline_m_; }
  int width() const { return width_; }
  int height() const { return height_; }
  // cx_right - cx_left (pixels): added to a disparity measured between the images to give the
  // disparity of the model, d = d_measured + offset.
  double disparityOffsetPx() const { return disparity_offset_px_; }
  // Pixels of disparity per image row from cy (see above).
  double disparityRowSlope() const { return disparity_row_slope_; }
  // What a matcher adds to a disparity measured at image row v: d = d_measured + this.
  double disparityCorrectionPx(double v) const {
    return disparity_offset_px_ + disparity_row_slope_ * (v - cy_);
  }

  // (u, v, d) of a point in the left camera frame; nullopt when it is not in front of the
  // camera (z <= 0 or not finite). J (optional) = d(u, v, d)/d(x, y, z).
  std::optional<Vec3> project(const Vec3& p_left, Mat3* J = nullptr) const;
  // The point in the left camera frame seen at (u, v) with disparity d; nullopt unless d > 0
  // and all finite. J (optional) = d(x, y, z)/d(u, v, d).
  std::optional<Vec3> backProject(const Vec3& uvd, Mat3* J = nullptr) const;

  // z = fx b / d (inf for d = 0) and its inverse.
  double depthFromDisparity(double disparity_px) const;
  double disparityFromDepth(double depth_m) const;

  // First-order covariance (m^2) of backProject(uvd) given the covariance of (u, v, d)
  // (px^2). Precondition: uvd back-projects (d > 0); otherwise an always-on check aborts.
  Mat3 backProjectionCovariance(const Vec3& uvd, const Mat3& uvd_covariance) const;
  // The same with independent noise: σ_u = σ_v = sigma_px, σ_d = sigma_disparity_px.
  Mat3 backProjectionCovariance(const Vec3& uvd, double sigma_px, double sigma_disparity_px) const;

  // Whether pixel (u, v) lies inside the image.
  bool inImage(double u, double v) const {
    return u >= 0.0 && v >= 0.0 && u < width_ && v < height_;
  }

  // "fx=458.600 fy=457.300 cx=367.200 cy=248.400 baseline=0.1100m 752x480", then
  // " disparity_offset=+0.800px" when the offset is not 0, " disparity_row_slope=+0.00400"
  // when the slope is not 0.
  std::string describe() const;

 private:
  StereoCamera() = default;
  Status validate() const;

  double fx_ = 0.0, fy_ = 0.0, cx_ = 0.0, cy_ = 0.0, baseline_m_ = 0.0, disparity_offset_px_ = 0.0;
  double disparity_row_slope_ = 0.0;
  int width_ = 0, height_ = 0;
};

}  // namespace evermap::core
