#include "core/camera/calibration.h"

#include <cmath>
#include <cstdio>

#include "core/common/quoted_number.h"

namespace evermap::core {
namespace {

bool positiveFinite(double v) { return std::isfinite(v) && v > 0.0; }

// Relative agreement of two intrinsics of a rectified pair.
bool same(double a, double b) { return std::abs(a - b) <= 1e-6 * std::max(1.0, std::abs(a)); }

}  // namespace

Status CameraCalibration::validate(const std::string& what) const {
  if (!positiveFinite(fx)) {
    return makeError(what, ": focal length fx = ", quotedNumberText(fx),
                     " must be positive and finite");
  }
  if (!positiveFinite(fy)) {
    return makeError(what, ": focal length fy = ", quotedNumberText(fy),
                     " must be positive and finite");
  }
  if (width <= 0 || height <= 0) {
    return makeError(what, ": image size ", width, "x", height, " must be positive");
  }
  if (!(std::isfinite(cx) && std::isfinite(cy) && cx >= 0.0 && cy >= 0.0 && cx < width &&
        cy < height)) {
    return makeError(what, ": principal point (", quotedNumberText(cx), ", ", quotedNumberText(cy),
                     ") is outside the ", width, "x", height, " image");
  }
  switch (distortion_model) {
    case DistortionModel::kNone:
      if (!distortion.empty()) {
        return makeError(what, ": distortion model none with ", distortion.size(), " coefficients");
      }
      break;
    case DistortionModel::kRadTan:
      if (distortion.size() != 4 && distortion.size() != 5) {
        return makeError(what,
                         ": radial-tangential distortion needs 4 or 5 coefficients "
                         "(k1 k2 p1 p2 [k3]), got ",
                         distortion.size());
      }
      break;
    default:
      return makeError(what, ": unknown distortion model ", static_cast<int>(distortion_model));
  }
  for (double k : distortion) {
    if (!std::isfinite(k)) return makeError(what, ": non-finite distortion coefficient");
  }
  if (!body_T_cam.translation().allFinite() || !body_T_cam.quaternion().coeffs().allFinite()) {
    return makeError(what, ": non-finite extrinsics body_T_cam");
  }
  return Ok{};
}

Status StereoCalibration::validate(const std::string& what) const {
  if (Status s = left.validate(what + ": left camera"); !s) return s;
  if (Status s = right.validate(what + ": right camera"); !s) return s;
  if (left.width != right.width || left.height != right.height) {
    return makeError(what, ": image sizes differ: left ", left.width, "x", left.height, ", right ",
                     right.width, "x", right.height);
  }
  const SE3d r_T_l = right_T_left();
  const double baseline = r_T_l.translation().norm();
  if (!(baseline > 1e-6)) {
    return makeError(what, ": baseline is ", quotedNumberText(baseline),
                     " m: the cameras are at the same place (identical extrinsics?)");
  }
  if (!rectified) return Ok{};

  if (left.distortion_model != DistortionModel::kNone ||
      right.distortion_model != DistortionModel::kNone) {
    return makeError(what, ": marked rectified but a camera has a distortion model");
  }
  // cx may differ: the disparity offset (StereoCamera); fx, fy and cy may not, or rows and
  // scales would differ between the images.
  if (!same(left.fx, right.fx) || !same(left.fy, right.fy) || !same(left.cy, right.cy)) {
    return makeError(what, ": marked rectified but the intrinsics differ: left fx fy cy = ",
                     quotedNumberText(left.fx), " ", quotedNumberText(left.fy), " ",
                     quotedNumberText(left.cy), ", right ", quotedNumberText(right.fx), " ",
                     quotedNumberText(right.fy), " ", quotedNumberText(right.cy));
  }
  const double offset = right.cx - left.cx;
  if (!(std::abs(offset) <= left.width / 4.0)) {
    return makeError(what,
                     ": marked rectified but the principal points differ by right cx - "
                     "left cx = ",
                     quotedNumberText(offset), " px, beyond a quarter of the ", left.width,
                     " px width (left cx ", quotedNumberText(left.cx), ", right cx ",
                     quotedNumberText(right.cx), ")");
  }
  if (rotationAngle(r_T_l.so3()) > 1e-6) {
    return makeError(what, ": marked rectified but the cameras are rotated by ",
                     quotedNumberText(rotationAngle(r_T_l.so3())), " rad");
  }
  // The right camera at +b along x of the left: p_right = p_left - (b, 0, 0).
  const Vec3 t = r_T_l.translation();
  if (std::abs(t.y()) > 1e-6 * baseline || std::abs(t.z()) > 1e-6 * baseline) {
    return makeError(what, ": marked rectified but the baseline is not along x: right_t_left = (",
                     quotedNumberText(t.x()), ", ", quotedNumberText(t.y()), ", ",
                     quotedNumberText(t.z()), ") m");
  }
  if (t.x() >= 0.0) {
    return makeError(what, ": the right camera is ", quotedNumberText(t.x()),
                     " m to the LEFT of the left camera (left and right swapped?)");
  }
  return Ok{};
}

Expected<StereoCamera> rectifiedStereoCamera(const StereoCalibration& c) {
  if (!c.rectified) {
    return makeError(
        "stereo calibration is not rectified: rectify the images first "
        "(StereoRectifier)");
  }
  if (Status s = c.validate(); !s) return s.error();
  return StereoCamera::create(c.left.fx, c.left.fy, c.left.cx, c.left.cy,
                              -c.right_T_left().translation().x(), c.left.width, c.left.height,
                              c.right.cx - c.left.cx);
}

Expected<StereoCalibration> withDisparityOffset(const StereoCalibration& c, double offset_px) {
  if (!c.rectified) {
    return makeError("disparity offset ", quotedNumberText(offset_px),
                     " px: the stereo calibration is not "
                     "rectified (a raw pair's rectification sets the rectified principal points)");
  }
  if (!std::isfinite(offset_px))
    return makeError("disparity offset ", quotedNumberText(offset_px), " px");
  StereoCalibration out = c;
  out.right.cx = c.left.cx + offset_px;
  if (Status s = out.validate(); !s) return s.error();
  return out;
}

}  // namespace evermap::core
