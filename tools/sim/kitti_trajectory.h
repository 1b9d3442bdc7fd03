#pragma once
// A session along a recorded trajectory: the KITTI odometry ground-truth poses (one line per
// frame, 12 numbers: the row-major 3x4 pose of camera 0 in the frame of camera 0 at frame 0;
// read by datasets::readKittiPoses).
//
// The KITTI camera becomes the simulator's camera: with C = body_T_cam (camera options),
// world_T_body(i) = C * P(i) * C^-1, so world_T_cam(i) = C * P(i): the world is z-up with the
// body of frame 0 at the origin, and camera deltas are exactly P(i-1)^-1 P(i). Frame i is at
// start_utime + i / rate_hz. Revisits are whatever the file has (00 has many loops).

#include <cstdint>

#include "core/common/expected.h"
#include "tools/sim/patrol.h"
#include "tools/sim/sensors.h"
#include "tools/sim/sim_options.h"

namespace evermap::sim {

Expected<SessionPlan> loadKittiSession(const TrajectoryOptions& options,
                                       const CameraOptions& camera, int64_t start_utime);

}  // namespace evermap::sim
