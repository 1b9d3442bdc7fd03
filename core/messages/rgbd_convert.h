#pragma once
// Conversions of the RGB-D frame message (lcmtypes/evermap_rgbd_image_t.lcm), beside
// convert.h's stereo ones and with the same contract: toMsg() refuses only what a caller
// could pass by mistake; fromMsg() checks everything a sender could get wrong and returns a
// one-line error naming the field (the depth's size, type, scale; the calibration; the gray
// image), never crashing on a malformed message.

#include <cstdint>

#include <opencv2/core.hpp>

#include <evermap/rgbd_image_t.hpp>

#include "core/camera/calibration.h"
#include "core/common/expected.h"
#include "core/messages/convert.h"

namespace evermap::messages {

// Depth of the image: CV_16UC1 in units of depth_scale_m, 0 = no depth (the Kinect's hole).
struct RgbdFrame {
  int64_t utime = 0;               // the gray image's exposure
  int64_t depth_utime = 0;         // the depth image's exposure
  cv::Mat gray;                    // CV_8UC1
  cv::Mat depth;                   // CV_16UC1, the gray image's size, registered to it
  double depth_scale_m = 0.0002;   // metres per unit (TUM and OpenNI: 1/5000)
  core::CameraCalibration camera;  // of the gray image

  // Depth in metres of a depth value (0 for no depth).
  double metres(uint16_t value) const { return value * depth_scale_m; }
};

// Largest |depth_utime - utime| a frame may carry: associations farther apart are not one
// frame (TUM's associate.py uses 0.02 s; a receiver allows a bit more).
inline constexpr int64_t kMaxDepthOffsetUs = 50000;

// Errors: a gray image or depth that is empty or of the wrong type, sizes that differ,
// a scale that is not positive and finite, a depth stamp more than kMaxDepthOffsetUs from the
// image's. `depth_encoding` kGray8 writes DEPTH_U16 (raw), kPng writes DEPTH_PNG16.
Expected<evermap::rgbd_image_t> toMsg(const RgbdFrame& frame, ImageEncoding encoding);

// The frame of a message: the calibration valid (CameraCalibration::validate) and of the
// image's size, the depth decoded (DEPTH_U16 or DEPTH_PNG16, 16-bit, one channel) and of the
// gray image's size, the scale positive and finite, the two stamps within kMaxDepthOffsetUs.
// The depth's size is checked before anything is decoded.
Expected<RgbdFrame> fromMsg(const evermap::rgbd_image_t& msg);

}  // namespace evermap::messages
