#include "tools/sim/kitti_trajectory.h"

#include <cmath>

#include "tools/datasets/kitti.h"

namespace evermap::sim {

Expected<SessionPlan> loadKittiSession(const TrajectoryOptions& o, const CameraOptions& camera,
                                       int64_t start_utime) {
  auto poses = datasets::readKittiPoses(o.file);
  if (!poses) return poses.error();
  const size_t first = static_cast<size_t>(o.first);
  const size_t end =
      o.count > 0 ? std::min(poses->size(), first + static_cast<size_t>(o.count)) : poses->size();
  if (first + 2 > end) {
    return makeError(o.file, ": ", poses->size(),
                     " poses, fewer than 2 from trajectory.first = ", o.first);
  }
  const SE3d body_T_cam = camera.bodyTCam();
  const SE3d cam_T_body = body_T_cam.inverse();
  const double period_us = 1e6 / o.rate_hz;
  std::vector<int64_t> utimes;
  std::vector<SE3d> world_T_body;
  for (size_t i = first; i < end; ++i) {
    utimes.push_back(start_utime + std::llround(static_cast<double>(i - first) * period_us));
    world_T_body.push_back(body_T_cam * (*poses)[i] * cam_T_body);
  }
  SessionPlan plan;
  plan.index = 0;
  auto trajectory = std::make_shared<SampledTrajectory>(std::move(utimes), std::move(world_T_body));
  plan.distance_m = trajectory->at(trajectory->endUtime()).odometer_m;
  plan.trajectory = std::move(trajectory);
  plan.floors_visited = {0};
  return plan;
}

}  // namespace evermap::sim
