#pragma once
// The camera's mounting on the body (body_T_cam of the rectified left camera) that the map's
// keyframe points need (map_scans.h): neither store holds it, so evermap-map-export reads it
// where the mapper did, from a log's first STEREO_CALIB (rectified: core/camera/
// stereo_rectifier.h) or RGBD_CALIB, or from the image-level simulator's camera.* settings.

#include <filesystem>

#include "core/common/expected.h"
#include "core/geometry/se3.h"

namespace evermap::map_export {

// The first STEREO_CALIB or RGBD_CALIB of `log` as the mapper latches it
// (mapper-proc/calibration_latch.h). Errors name the log (none there, one that does not
// validate).
Expected<core::SE3d> mountingFromLog(const std::filesystem::path& log);

}  // namespace evermap::map_export
