#include "mapper-proc/calibration_latch.h"

#include <algorithm>

#include <evermap/rgbd_calib_t.hpp>
#include <evermap/stereo_calib_t.hpp>

#include "core/camera/stereo_rectifier.h"
#include "core/messages/channels.h"
#include "core/messages/convert.h"

namespace evermap::mapper {

template <typename Msg, typename Mounting>
Status CalibrationLatch::latch(const void* data, int64_t size, const char* channel,
                               const SetMounting& set, Mounting mounting) {
  const auto* p = static_cast<const uint8_t*>(data);
  std::vector<uint8_t> bytes(p, p + std::max<int64_t>(0, size));
  // The LCM fingerprint (8 bytes) and utime (8 bytes) lead the encoding.
  if (bytes.size() >= 16) std::fill(bytes.begin(), bytes.begin() + 16, 0);
  if (have_camera_ && bytes == last_) return Ok{};
  auto msg = messages::decodeLcm<Msg>(data, size, channel);
  if (!msg) {
    ++counts_.undecodable;
    return msg.error();
  }
  const Expected<core::SE3d> body_T_cam = mounting(*msg);
  if (!body_T_cam) {
    ++counts_.refused;
    return makeError(channel, " ", msg->utime, ": ", body_T_cam.error().message);
  }
  set(*body_T_cam);
  have_camera_ = true;
  last_ = std::move(bytes);
  ++counts_.camera_changes;
  return Ok{};
}

Status CalibrationLatch::handle(const void* data, int64_t size, Mapper& mapper) {
  return handle(data, size, [&mapper](const core::SE3d& m) { mapper.setCameraMounting(m); });
}

Status CalibrationLatch::handleRgbd(const void* data, int64_t size, Mapper& mapper) {
  return handleRgbd(data, size, [&mapper](const core::SE3d& m) { mapper.setCameraMounting(m); });
}

Status CalibrationLatch::handle(const void* data, int64_t size, const SetMounting& set) {
  return latch<stereo_calib_t>(data, size, channels::kStereoCalib, set,
                               [](const stereo_calib_t& msg) -> Expected<core::SE3d> {
                                 auto calibration = messages::fromMsg(msg);
                                 if (!calibration) return calibration.error();
                                 return core::rectifiedLeftBodyTCamera(*calibration);
                               });
}

Status CalibrationLatch::handleRgbd(const void* data, int64_t size, const SetMounting& set) {
  return latch<rgbd_calib_t>(data, size, channels::kRgbdCalib, set,
                             [](const rgbd_calib_t& msg) -> Expected<core::SE3d> {
                               auto camera = messages::fromMsg(msg.camera);
                               if (!camera) return camera.error();
                               return camera->body_T_cam;
                             });
}

}  // namespace evermap::mapper
