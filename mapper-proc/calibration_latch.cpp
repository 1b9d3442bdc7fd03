#include "mapper-proc/calibration_latch.h"

#include <algorithm>

#include <evermap/rgbd_calib_t.hpp>
#include <evermap/stereo_calib_t.hpp>

#include "core/camera/stereo_rectifier.h"
#include "core/messages/channels.h"
#include "core/messages/convert.h"

namespace evermap::mapper {

Status CalibrationLatch::handle(const void* data, int64_t size, Mapper& mapper) {
  const auto* p = static_cast<const uint8_t*>(data);
  std::vector<uint8_t> bytes(p, p + std::max<int64_t>(0, size));
  // The LCM fingerprint (8 bytes) and utime (8 bytes) lead the encoding.
  if (bytes.size() >= 16) std::fill(bytes.begin(), bytes.begin() + 16, 0);
  if (have_camera_ && bytes == last_) return Ok{};
  auto msg = messages::decodeLcm<stereo_calib_t>(data, size, channels::kStereoCalib);
  if (!msg) {
    ++counts_.undecodable;
    return msg.error();
  }
  auto calibration = messages::fromMsg(*msg);
  Expected<core::SE3d> body_T_cam =
      calibration ? core::rectifiedLeftBodyTCamera(*calibration) : Expected<core::SE3d>(calibration.error());
  if (!body_T_cam) {
    ++counts_.refused;
    return makeError("STEREO_CALIB ", msg->utime, ": ", body_T_cam.error().message);
  }
  mapper.setCameraMounting(*body_T_cam);
  have_camera_ = true;
  last_ = std::move(bytes);
  ++counts_.camera_changes;
  return Ok{};
}

Status CalibrationLatch::handleRgbd(const void* data, int64_t size, Mapper& mapper) {
  const auto* p = static_cast<const uint8_t*>(data);
  std::vector<uint8_t> bytes(p, p + std::max<int64_t>(0, size));
  if (bytes.size() >= 16) std::fill(bytes.begin(), bytes.begin() + 16, 0);
  if (have_camera_ && bytes == last_) return Ok{};
  auto msg = messages::decodeLcm<rgbd_calib_t>(data, size, channels::kRgbdCalib);
  if (!msg) {
    ++counts_.undecodable;
    return msg.error();
  }
  auto camera = messages::fromMsg(msg->camera);
  if (!camera) {
    ++counts_.refused;
    return makeError("RGBD_CALIB ", msg->utime, ": ", camera.error().message);
  }
  mapper.setCameraMounting(camera->body_T_cam);
  have_camera_ = true;
  last_ = std::move(bytes);
  ++counts_.camera_changes;
  return Ok{};
}

}  // namespace evermap::mapper
