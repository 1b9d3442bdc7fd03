#pragma once
// Conversions between evermap's core types and its LCM messages (lcmtypes/*.lcm).
//
// toMsg() never fails for a valid core value (a broken contract, e.g. an image that is not
// 8-bit gray, is returned as an Error where the caller may pass arbitrary data). fromMsg()
// is what a receiver calls on whatever arrived: it checks lengths, sizes, finiteness and
// ranges, and returns an Error with a one-line message naming the field; it never crashes
// on a malformed message. decodeLcm() is the step before it, from bytes off the wire.
//
// Time: utime is microseconds; data-set stamps in nanoseconds are rounded to the nearest
// microsecond (utimeFromNs).

#include <climits>
#include <cstdint>
#include <exception>
#include <filesystem>
#include <string>

#include <opencv2/core.hpp>

#include <evermap/camera_calib_t.hpp>
#include <evermap/image_t.hpp>
#include <evermap/pose_t.hpp>
#include <evermap/stereo_calib_t.hpp>
#include <evermap/stereo_image_t.hpp>

#include "core/camera/calibration.h"
#include "core/common/expected.h"
#include "core/geometry/se3.h"
#include "core/messages/image_codec.h"
#include "core/messages/wire_check.h"

namespace evermap::messages {

// Nanoseconds to microseconds, rounded to the nearest (halves away from -inf).
int64_t utimeFromNs(int64_t t_ns);
inline int64_t nsFromUtime(int64_t utime) { return utime * 1000; }

// ---- Images ----
// Encodings, kMaxImageSide and the codec itself: image_codec.h.
// `image` must be CV_8UC1 and non-empty.
Expected<evermap::image_t> toMsg(const cv::Mat& image, int64_t utime, ImageEncoding encoding);
// The image of a message, CV_8UC1 of width x height (a copy, independent of the message).
Expected<cv::Mat> fromMsg(const evermap::image_t& msg);

// An image file (any format OpenCV reads) as a message: it must decode to 8-bit gray, and is
// then encoded as asked (a PNG file is re-encoded too: lossless either way). Errors name the
// file.
Expected<evermap::image_t> imageMsgFromFile(const std::filesystem::path& file, int64_t utime,
                                            ImageEncoding encoding);

struct StereoFrame {
  int64_t utime = 0;
  bool rectified = false;
  cv::Mat left;   // CV_8UC1
  cv::Mat right;  // CV_8UC1, same size as left
};
Expected<evermap::stereo_image_t> toMsg(const StereoFrame& frame, ImageEncoding encoding);
// Both images decoded and of the same size.
Expected<StereoFrame> fromMsg(const evermap::stereo_image_t& msg);

// ---- Calibration ----
evermap::camera_calib_t toMsg(const core::CameraCalibration& calibration);
Expected<core::CameraCalibration> fromMsg(const evermap::camera_calib_t& msg);
evermap::stereo_calib_t toMsg(const core::StereoCalibration& calibration, int64_t utime);
// Each camera checked, then the pair (StereoCalibration::validate).
Expected<core::StereoCalibration> fromMsg(const evermap::stereo_calib_t& msg);

// ---- IMU ----
// imu_t <-> imu::ImuSample: core/imu/lcm_convert.h (a sample's checks are the SampleGate's).

// ---- Poses ----
evermap::pose_t toMsg(int64_t utime, const core::UncertainPose& pose, int32_t floor = -1,
                      int32_t session = -1);
// The quaternion must be unit within 1e-3 (it is then normalised); the covariance finite,
// symmetric and with a non-negative diagonal. Floor and session are read from msg directly.
Expected<core::UncertainPose> fromMsg(const evermap::pose_t& msg);

// ---- Bytes off the wire ----
// Decodes an LCM message of type Msg, the one decoding path of every receiver: the buffer is
// first walked along Msg's wire layout (checkWire, generated for every type: the type hash,
// every array and string length against the bytes present), so lcm-gen's decoder never
// allocates for a length that is not there; an exception from it is caught all the same.
// Errors (wrong type, truncation, trailing bytes, absurd lengths) are one line naming `what`
// (normally the channel) and the member.
template <typename Msg>
Expected<Msg> decodeLcm(const void* data, int64_t size, const std::string& what) {
  if (data == nullptr || size < 0 || size > INT_MAX) {
    return makeError(what, ": ", size, " bytes is not a valid ", Msg::getTypeName());
  }
  const Expected<int64_t> used = checkWire<Msg>(data, size);
  if (!used) {
    return makeError(what, ": not a valid ", Msg::getTypeName(), " (", used.error().message, ")");
  }
  if (*used != size) {
    return makeError(what, ": ", Msg::getTypeName(), " of ", *used, " bytes followed by ",
                     size - *used, " unexpected bytes");
  }
  Msg msg;
  try {
    if (msg.decode(data, 0, static_cast<int>(size)) != size) {
      return makeError(what, ": not a valid ", Msg::getTypeName(), " (", size,
                       " bytes the layout accepts and the decoder does not)");
    }
  } catch (const std::exception& e) {
    return makeError(what, ": malformed ", Msg::getTypeName(), " (", e.what(), ")");
  }
  return msg;
}

}  // namespace evermap::messages
