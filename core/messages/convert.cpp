#include "core/messages/convert.h"

#include <cmath>
#include <cstring>
#include <fstream>
#include <future>
#include <iterator>
#include <vector>

#include "core/common/finite.h"
#include "core/messages/pose_fields.h"

namespace evermap::messages {
namespace {

// The image size and the pinhole intrinsics, which core::CameraCalibration and camera_calib_t
// name alike.
template <class From, class To>
void copyIntrinsics(const From& from, To& to) {
  to.width = from.width;
  to.height = from.height;
  to.fx = from.fx;
  to.fy = from.fy;
  to.cx = from.cx;
  to.cy = from.cy;
}

}  // namespace

int64_t utimeFromNs(int64_t t_ns) {
  // floor((t_ns + 500) / 1000) without overflow for negative stamps.
  const int64_t shifted = t_ns + 500;
  int64_t q = shifted / 1000;
  if (shifted % 1000 < 0) --q;
  return q;
}

Expected<evermap::image_t> toMsg(const cv::Mat& image, int64_t utime, ImageEncoding encoding) {
  auto encoded = encodeImage(image, encoding, "image at utime " + std::to_string(utime));
  if (!encoded) return encoded.error();
  evermap::image_t msg;
  msg.utime = utime;
  msg.width = image.cols;
  msg.height = image.rows;
  msg.pixelformat = encoded->pixelformat;
  msg.row_stride = encoded->row_stride;
  msg.data = std::move(encoded->data);
  msg.size = static_cast<int32_t>(msg.data.size());
  return msg;
}

Expected<cv::Mat> fromMsg(const evermap::image_t& msg) {
  const std::string what = "image_t at utime " + std::to_string(msg.utime);
  if (msg.size < 0 || static_cast<size_t>(msg.size) != msg.data.size()) {
    return makeError(what, ": size field ", msg.size, " but ", msg.data.size(), " data bytes");
  }
  return decodeImage(msg.pixelformat, msg.width, msg.height, msg.row_stride, msg.data, what);
}

Expected<evermap::image_t> imageMsgFromFile(const std::filesystem::path& file, int64_t utime,
                                            ImageEncoding encoding) {
  const std::string name = file.string();
  std::ifstream in(file, std::ios::binary);
  if (!in) return makeError(name, ": cannot open");
  std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(in)),
                             std::istreambuf_iterator<char>());
  if (in.bad()) return makeError(name, ": read error");
  if (bytes.empty()) return makeError(name, ": empty file");
  // Always re-encoded: data-set PNGs are often stored nearly uncompressed (EuRoC's are 362 KB
  // for 361 KB of pixels); the default zstd rows halve them and decode ~7x faster than PNG.
  auto image = decodeImageFile(bytes, name);
  if (!image) return image.error();
  auto msg = toMsg(*image, utime, encoding);
  if (!msg) return makeError(name, ": ", msg.error().message);
  return msg;
}

Expected<evermap::stereo_image_t> toMsg(const StereoFrame& frame, ImageEncoding encoding) {
  if (frame.left.size() != frame.right.size()) {
    return makeError("stereo frame at utime ", frame.utime, ": left ", frame.left.cols, "x",
                     frame.left.rows, " and right ", frame.right.cols, "x", frame.right.rows,
                     " differ in size");
  }
  auto left = toMsg(frame.left, frame.utime, encoding);
  if (!left) return left.error();
  auto right = toMsg(frame.right, frame.utime, encoding);
  if (!right) return right.error();
  evermap::stereo_image_t msg;
  msg.utime = frame.utime;
  msg.rectified = frame.rectified ? 1 : 0;
  msg.left = std::move(*left);
  msg.right = std::move(*right);
  return msg;
}

Expected<StereoFrame> fromMsg(const evermap::stereo_image_t& msg) {
  const std::string what = "stereo_image_t at utime " + std::to_string(msg.utime);
  if (msg.rectified != 0 && msg.rectified != 1) {
    return makeError(what, ": rectified must be 0 or 1, is ", int{msg.rectified});
  }
  // The right image on a second thread while this one decodes the left (raw images are only
  // copied: not worth a thread).
  const bool parallel = msg.right.pixelformat != evermap::image_t::FORMAT_GRAY8;
  std::future<Expected<cv::Mat>> right_job = std::async(
      parallel ? std::launch::async : std::launch::deferred, [&msg] { return fromMsg(msg.right); });
  auto left = fromMsg(msg.left);
  auto right = right_job.get();
  if (!left) return makeError(what, ": left: ", left.error().message);
  if (!right) return makeError(what, ": right: ", right.error().message);
  if (left->size() != right->size()) {
    return makeError(what, ": left ", left->cols, "x", left->rows, " and right ", right->cols, "x",
                     right->rows, " differ in size");
  }
  StereoFrame frame;
  frame.utime = msg.utime;
  frame.rectified = msg.rectified == 1;
  frame.left = std::move(*left);
  frame.right = std::move(*right);
  return frame;
}

evermap::camera_calib_t toMsg(const core::CameraCalibration& c) {
  evermap::camera_calib_t msg;
  copyIntrinsics(c, msg);
  msg.distortion_model = static_cast<int8_t>(c.distortion_model);
  msg.distortion = c.distortion;
  msg.num_distortion = static_cast<int32_t>(c.distortion.size());
  const core::Mat4 T = c.body_T_cam.matrix();
  for (int r = 0; r < 4; ++r) {
    for (int k = 0; k < 4; ++k) msg.body_T_cam[4 * r + k] = T(r, k);
  }
  return msg;
}

Expected<core::CameraCalibration> fromMsg(const evermap::camera_calib_t& msg) {
  const std::string what = "camera_calib_t";
  if (msg.num_distortion < 0 || static_cast<size_t>(msg.num_distortion) != msg.distortion.size()) {
    return makeError(what, ": num_distortion ", msg.num_distortion, " but ", msg.distortion.size(),
                     " coefficients");
  }
  core::CameraCalibration c;
  copyIntrinsics(msg, c);
  if (msg.distortion_model != evermap::camera_calib_t::DISTORTION_NONE &&
      msg.distortion_model != evermap::camera_calib_t::DISTORTION_RADTAN) {
    return makeError(what, ": unknown distortion_model ", int{msg.distortion_model});
  }
  c.distortion_model = static_cast<core::DistortionModel>(msg.distortion_model);
  c.distortion = msg.distortion;
  if (!allFinite(msg.body_T_cam, 16)) return makeError(what, ": non-finite body_T_cam");
  core::Mat4 T;
  for (int r = 0; r < 4; ++r) {
    for (int k = 0; k < 4; ++k) T(r, k) = msg.body_T_cam[4 * r + k];
  }
  const core::Mat3 R = T.topLeftCorner<3, 3>();
  if ((R.transpose() * R - core::Mat3::Identity()).cwiseAbs().maxCoeff() > 1e-6 ||
      R.determinant() < 0.0 ||
      (T.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() > 1e-9) {
    return makeError(what, ": body_T_cam is not a rigid transform");
  }
  c.body_T_cam = core::SE3d::fromMatrix(T);
  if (Status s = c.validate(what); !s) return s.error();
  return c;
}

evermap::stereo_calib_t toMsg(const core::StereoCalibration& c, int64_t utime) {
  evermap::stereo_calib_t msg;
  msg.utime = utime;
  msg.rectified = c.rectified ? 1 : 0;
  msg.left = toMsg(c.left);
  msg.right = toMsg(c.right);
  return msg;
}

Expected<core::StereoCalibration> fromMsg(const evermap::stereo_calib_t& msg) {
  const std::string what = "stereo_calib_t at utime " + std::to_string(msg.utime);
  if (msg.rectified != 0 && msg.rectified != 1) {
    return makeError(what, ": rectified must be 0 or 1, is ", int{msg.rectified});
  }
  core::StereoCalibration c;
  c.rectified = msg.rectified == 1;
  auto left = fromMsg(msg.left);
  if (!left) return makeError(what, ": left: ", left.error().message);
  auto right = fromMsg(msg.right);
  if (!right) return makeError(what, ": right: ", right.error().message);
  c.left = std::move(*left);
  c.right = std::move(*right);
  if (Status s = c.validate(what); !s) return s.error();
  return c;
}

evermap::pose_t toMsg(int64_t utime, const core::UncertainPose& pose, int32_t floor,
                      int32_t session) {
  evermap::pose_t msg;
  msg.utime = utime;
  putPose(pose.mean, msg.position, msg.orientation);
  for (int r = 0; r < 6; ++r) {
    for (int k = 0; k < 6; ++k) msg.covariance[6 * r + k] = pose.covariance(r, k);
  }
  msg.floor = floor;
  msg.session = session;
  return msg;
}

Expected<core::UncertainPose> fromMsg(const evermap::pose_t& msg) {
  const std::string what = "pose_t at utime " + std::to_string(msg.utime);
  const Expected<core::SE3d> mean = poseFromMessage(msg.position, msg.orientation, what.c_str());
  if (!mean) return mean.error();
  if (!allFinite(msg.covariance, 36)) return makeError(what, ": non-finite covariance");
  core::UncertainPose pose;
  for (int r = 0; r < 6; ++r) {
    for (int k = 0; k < 6; ++k) pose.covariance(r, k) = msg.covariance[6 * r + k];
  }
  const double scale = std::max(1.0, pose.covariance.cwiseAbs().maxCoeff());
  if ((pose.covariance - pose.covariance.transpose()).cwiseAbs().maxCoeff() > 1e-9 * scale) {
    return makeError(what, ": covariance is not symmetric");
  }
  if ((pose.covariance.diagonal().array() < 0.0).any()) {
    return makeError(what, ": covariance has a negative variance");
  }
  pose.mean = *mean;
  return pose;
}

}  // namespace evermap::messages
