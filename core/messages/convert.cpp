#include "core/messages/convert.h"

#include <array>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "core/messages/pose_fields.h"

namespace evermap::messages {
namespace {

constexpr std::array<uint8_t, 8> kPngSignature = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};

bool isPng(const std::vector<uint8_t>& bytes) {
  return bytes.size() >= kPngSignature.size() &&
         std::memcmp(bytes.data(), kPngSignature.data(), kPngSignature.size()) == 0;
}

// Width and height from a PNG's IHDR chunk (bytes 16..23, big-endian), read before decoding
// so a message cannot make the decoder allocate more than it announced.
bool pngSize(const std::vector<uint8_t>& bytes, int64_t* width, int64_t* height) {
  if (bytes.size() < 24 || std::memcmp(bytes.data() + 12, "IHDR", 4) != 0) return false;
  auto be32 = [&bytes](size_t at) {
    return (int64_t{bytes[at]} << 24) | (int64_t{bytes[at + 1]} << 16) |
           (int64_t{bytes[at + 2]} << 8) | int64_t{bytes[at + 3]};
  };
  *width = be32(16);
  *height = be32(20);
  return true;
}

Expected<cv::Mat> decodeGray(const std::vector<uint8_t>& bytes, const std::string& what) {
  cv::Mat image;
  try {
    image = cv::imdecode(bytes, cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& e) {
    return makeError(what, ": cannot decode the image (", e.msg, ")");
  }
  if (image.empty()) return makeError(what, ": corrupt or unsupported image data");
  if (image.type() != CV_8UC1) {
    return makeError(what, ": not an 8-bit gray image (", image.channels(), " channels, depth ",
                     image.depth(), ")");
  }
  return image;
}

bool finite(const double* v, int n) {
  for (int i = 0; i < n; ++i) {
    if (!std::isfinite(v[i])) return false;
  }
  return true;
}

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

const char* toString(ImageEncoding e) {
  switch (e) {
    case ImageEncoding::kGray8:
      return "gray8";
    case ImageEncoding::kPng:
      return "png";
  }
  return "?";
}

Expected<evermap::image_t> toMsg(const cv::Mat& image, int64_t utime, ImageEncoding encoding) {
  if (image.empty() || image.type() != CV_8UC1) {
    return makeError("image at utime ", utime, ": must be a non-empty 8-bit gray image");
  }
  evermap::image_t msg;
  msg.utime = utime;
  msg.width = image.cols;
  msg.height = image.rows;
  if (encoding == ImageEncoding::kGray8) {
    msg.pixelformat = evermap::image_t::FORMAT_GRAY8;
    msg.row_stride = image.cols;
    msg.data.resize(static_cast<size_t>(image.cols) * image.rows);
    for (int r = 0; r < image.rows; ++r) {
      std::memcpy(msg.data.data() + static_cast<size_t>(r) * image.cols, image.ptr(r), image.cols);
    }
  } else {
    msg.pixelformat = evermap::image_t::FORMAT_PNG;
    msg.row_stride = 0;
    try {
      if (!cv::imencode(".png", image, msg.data)) {
        return makeError("image at utime ", utime, ": PNG encoding failed");
      }
    } catch (const cv::Exception& e) {
      return makeError("image at utime ", utime, ": PNG encoding failed (", e.msg, ")");
    }
  }
  msg.size = static_cast<int32_t>(msg.data.size());
  return msg;
}

Expected<cv::Mat> fromMsg(const evermap::image_t& msg) {
  const std::string what = "image_t at utime " + std::to_string(msg.utime);
  if (msg.width <= 0 || msg.height <= 0 || msg.width > kMaxImageSide ||
      msg.height > kMaxImageSide) {
    return makeError(what, ": size ", msg.width, "x", msg.height, " is not in 1..", kMaxImageSide);
  }
  if (msg.size < 0 || static_cast<size_t>(msg.size) != msg.data.size()) {
    return makeError(what, ": size field ", msg.size, " but ", msg.data.size(), " data bytes");
  }
  if (msg.pixelformat == evermap::image_t::FORMAT_GRAY8) {
    if (msg.row_stride < msg.width) {
      return makeError(what, ": row_stride ", msg.row_stride, " is less than width ", msg.width);
    }
    const int64_t need = int64_t{msg.row_stride} * msg.height;
    if (msg.size != need) {
      return makeError(what, ": gray8 ", msg.width, "x", msg.height, " with stride ",
                       msg.row_stride, " needs ", need, " bytes, has ", msg.size);
    }
    cv::Mat image(msg.height, msg.width, CV_8UC1);
    for (int r = 0; r < msg.height; ++r) {
      std::memcpy(image.ptr(r), msg.data.data() + static_cast<size_t>(r) * msg.row_stride,
                  msg.width);
    }
    return image;
  }
  if (msg.pixelformat == evermap::image_t::FORMAT_PNG) {
    if (msg.row_stride != 0) {
      return makeError(what, ": row_stride must be 0 for PNG, is ", msg.row_stride);
    }
    int64_t w = 0, h = 0;
    if (!isPng(msg.data) || !pngSize(msg.data, &w, &h)) {
      return makeError(what, ": pixelformat PNG but the data is not a PNG");
    }
    if (w != msg.width || h != msg.height) {
      return makeError(what, ": the PNG is ", w, "x", h, ", the message says ", msg.width, "x",
                       msg.height);
    }
    auto image = decodeGray(msg.data, what);
    if (!image) return image.error();
    if (image->cols != msg.width || image->rows != msg.height) {
      return makeError(what, ": decoded ", image->cols, "x", image->rows, ", the message says ",
                       msg.width, "x", msg.height);
    }
    return image;
  }
  return makeError(what, ": unknown pixelformat ", msg.pixelformat);
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
  // for 361 KB of pixels); OpenCV's default PNG settings halve them at ~4 ms per image.
  auto image = decodeGray(bytes, name);
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
  auto left = fromMsg(msg.left);
  if (!left) return makeError(what, ": left: ", left.error().message);
  auto right = fromMsg(msg.right);
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
  if (!finite(msg.body_T_cam, 16)) return makeError(what, ": non-finite body_T_cam");
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

evermap::imu_t toMsg(const ImuSample& s) {
  evermap::imu_t msg;
  msg.utime = utimeFromNs(s.t_ns);
  for (int i = 0; i < 3; ++i) {
    msg.angular_velocity[i] = s.gyro_rad_s[i];
    msg.linear_acceleration[i] = s.accel_m_s2[i];
  }
  return msg;
}

imu::ImuSample toImuSample(const ImuSample& s) {
  return {utimeFromNs(s.t_ns), s.gyro_rad_s, s.accel_m_s2};
}

Expected<ImuSample> fromMsg(const evermap::imu_t& msg) {
  if (!finite(msg.angular_velocity, 3) || !finite(msg.linear_acceleration, 3)) {
    return makeError("imu_t at utime ", msg.utime, ": non-finite value");
  }
  ImuSample s;
  s.t_ns = nsFromUtime(msg.utime);
  s.gyro_rad_s =
      Eigen::Vector3d(msg.angular_velocity[0], msg.angular_velocity[1], msg.angular_velocity[2]);
  s.accel_m_s2 = Eigen::Vector3d(msg.linear_acceleration[0], msg.linear_acceleration[1],
                                 msg.linear_acceleration[2]);
  return s;
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
  if (!finite(msg.covariance, 36)) return makeError(what, ": non-finite covariance");
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
