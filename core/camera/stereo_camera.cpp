#include "core/camera/stereo_camera.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>

#include "core/common/quoted_number.h"

namespace evermap::core {
Expected<StereoCamera> StereoCamera::create(double fx, double fy, double cx, double cy,
                                            double baseline_m, int width, int height,
                                            double disparity_offset_px,
                                            double disparity_row_slope) {
  StereoCamera c;
  c.fx_ = fx;
  c.fy_ = fy;
  c.cx_ = cx;
  c.cy_ = cy;
  c.baseline_m_ = baseline_m;
  c.width_ = width;
  c.height_ = height;
  c.disparity_offset_px_ = disparity_offset_px;
  c.disparity_row_slope_ = disparity_row_slope;
  if (Status s = c.validate(); !s) return s.error();
  return c;
}

Status StereoCamera::validate() const {
  const char* who = "stereo camera: ";
  if (!(std::isfinite(fx_) && fx_ > 0.0)) {
    return makeError(who, "focal length fx = ", quotedNumberText(fx_),
                     " must be positive and finite");
  }
  if (!(std::isfinite(fy_) && fy_ > 0.0)) {
    return makeError(who, "focal length fy = ", quotedNumberText(fy_),
                     " must be positive and finite");
  }
  if (!(std::isfinite(baseline_m_) && baseline_m_ > 0.0)) {
    return makeError(who, "baseline = ", quotedNumberText(baseline_m_),
                     " m must be positive and finite (right camera at +x of the left)");
  }
  if (width_ <= 0 || height_ <= 0) {
    return makeError(who, "image size ", width_, "x", height_, " must be positive");
  }
  if (!(std::isfinite(cx_) && std::isfinite(cy_) && cx_ >= 0.0 && cy_ >= 0.0 && cx_ < width_ &&
        cy_ < height_)) {
    return makeError(who, "principal point (", quotedNumberText(cx_), ", ", quotedNumberText(cy_),
                     ") is outside the ", width_, "x", height_, " image");
  }
  // A quarter of the width is far beyond any rectification error (KITTI's clip: 0.8 px of
  // 1241) and still refuses a right camera's cx given in another image's coordinates.
  if (!(std::isfinite(disparity_offset_px_) && std::abs(disparity_offset_px_) <= width_ / 4.0)) {
    return makeError(
        who, "disparity offset cx_right - cx_left = ", quotedNumberText(disparity_offset_px_),
        " px is not finite or beyond a quarter of the ", width_,
        " px width (a rectified pair's principal points differ by little)");
  }
  if (!(std::isfinite(disparity_row_slope_) &&
        std::abs(disparity_row_slope_) * height_ <= width_ / 4.0)) {
    return makeError(
        who, "disparity row slope ", quotedNumberText(disparity_row_slope_),
        " px per row is not finite or moves disparities by more than a quarter of the ", width_,
        " px width over the ", height_, " rows");
  }
  return Ok{};
}

std::optional<StereoCamera::Vec3> StereoCamera::project(const Vec3& p, Mat3* J) const {
  if (!p.allFinite() || !(p.z() > 0.0)) return std::nullopt;
  const double iz = 1.0 / p.z();
  const Vec3 uvd(fx_ * p.x() * iz + cx_, fy_ * p.y() * iz + cy_, fx_ * baseline_m_ * iz);
  if (J) {
    const double iz2 = iz * iz;
    *J << fx_ * iz, 0.0, -fx_ * p.x() * iz2, 0.0, fy_ * iz, -fy_ * p.y() * iz2, 0.0, 0.0,
        -fx_ * baseline_m_ * iz2;
  }
  return uvd;
}

std::optional<StereoCamera::Vec3> StereoCamera::backProject(const Vec3& uvd, Mat3* J) const {
  const double d = uvd.z();
  if (!uvd.allFinite() || !(d > 0.0)) return std::nullopt;
  // z = fx b / d; x = (u - cx) z / fx = (u - cx) b / d; y = (v - cy) z / fy.
  const double b_d = baseline_m_ / d;
  const double du = uvd.x() - cx_;
  const double dv = uvd.y() - cy_;
  const double r = fx_ / fy_;
  const Vec3 p(du * b_d, dv * r * b_d, fx_ * b_d);
  if (J) {
    const double b_d2 = b_d / d;
    *J << b_d, 0.0, -du * b_d2, 0.0, r * b_d, -dv * r * b_d2, 0.0, 0.0, -fx_ * b_d2;
  }
  return p;
}

double StereoCamera::depthFromDisparity(double disparity_px) const {
  if (disparity_px == 0.0) return std::numeric_limits<double>::infinity();
  return fx_ * baseline_m_ / disparity_px;
}

double StereoCamera::disparityFromDepth(double depth_m) const {
  if (depth_m == 0.0) return std::numeric_limits<double>::infinity();
  return fx_ * baseline_m_ / depth_m;
}

StereoCamera::Mat3 StereoCamera::backProjectionCovariance(const Vec3& uvd,
                                                          const Mat3& uvd_covariance) const {
  Mat3 J;
  if (!backProject(uvd, &J)) {
    std::fprintf(stderr, "evermap: backProjectionCovariance needs a positive disparity, got %g\n",
                 uvd.z());
    std::abort();
  }
  // Matthies & Shafer (1987): first-order propagation through the back-projection.
  return J * uvd_covariance * J.transpose();
}

StereoCamera::Mat3 StereoCamera::backProjectionCovariance(const Vec3& uvd, double sigma_px,
                                                          double sigma_disparity_px) const {
  const Vec3 var(sigma_px * sigma_px, sigma_px * sigma_px, sigma_disparity_px * sigma_disparity_px);
  return backProjectionCovariance(uvd, Mat3(var.asDiagonal()));
}

std::string StereoCamera::describe() const {
  char buf[200];
  const int n =
      std::snprintf(buf, sizeof buf, "fx=%.3f fy=%.3f cx=%.3f cy=%.3f baseline=%.4fm %dx%d", fx_,
                    fy_, cx_, cy_, baseline_m_, width_, height_);
  std::string out = n > 0 ? buf : "";
  if (disparity_offset_px_ != 0.0) {
    std::snprintf(buf, sizeof buf, " disparity_offset=%+.3fpx", disparity_offset_px_);
    out += buf;
  }
  if (disparity_row_slope_ != 0.0) {
    std::snprintf(buf, sizeof buf, " disparity_row_slope=%+.5f", disparity_row_slope_);
    out += buf;
  }
  return out;
}

}  // namespace evermap::core
