#include "tools/map-export/camera_mounting.h"

#include <cstring>

#include <evermap/rgbd_calib_t.hpp>
#include <evermap/stereo_calib_t.hpp>

#include "core/camera/stereo_rectifier.h"
#include "core/messages/channels.h"
#include "core/messages/convert.h"
#include "tools/lcmlog/log_reader.h"

namespace evermap::map_export {

Expected<core::SE3d> mountingFromLog(const std::filesystem::path& log) {
  auto reader = messages::LogReader::open(log);
  if (!reader) return reader.error();
  const std::string name = log.string() + ": ";
  while (const messages::LogReader::Event* e = reader->next()) {
    if (e->channel == channels::kStereoCalib) {
      auto msg =
          messages::decodeLcm<evermap::stereo_calib_t>(e->data, e->datalen, name + e->channel);
      if (!msg) return msg.error();
      auto calibration = messages::fromMsg(*msg);
      if (!calibration) return makeError(name, calibration.error().message);
      auto mounting = core::rectifiedLeftBodyTCamera(*calibration);
      if (!mounting) return makeError(name, mounting.error().message);
      return *mounting;
    }
    if (e->channel == channels::kRgbdCalib) {
      auto msg = messages::decodeLcm<evermap::rgbd_calib_t>(e->data, e->datalen, name + e->channel);
      if (!msg) return msg.error();
      auto camera = messages::fromMsg(msg->camera);
      if (!camera) return makeError(name, camera.error().message);
      return camera->body_T_cam;
    }
  }
  if (Status s = reader->status(); !s) return s.error();
  return makeError(name, "no STEREO_CALIB or RGBD_CALIB in the log (--calib)");
}

}  // namespace evermap::map_export
