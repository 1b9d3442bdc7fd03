#include "core/sim/kitti_trajectory.h"

#include <cmath>
#include <fstream>
#include <sstream>

namespace evermap::sim {

Expected<SessionPlan> loadKittiSession(const TrajectoryOptions& o, const CameraOptions& camera,
                                       int64_t start_utime) {
  std::ifstream in(o.file);
  if (!in) return makeError(o.file, ": cannot open trajectory file");
  const SE3d body_T_cam = camera.bodyTCam();
  const SE3d cam_T_body = body_T_cam.inverse();
  std::vector<int64_t> utimes;
  std::vector<SE3d> poses;
  std::string line;
  int number = 0;
  const double period_us = 1e6 / o.rate_hz;
  while (std::getline(in, line)) {
    ++number;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    const int frame = number - 1;
    if (frame < o.first) continue;
    if (o.count > 0 && frame >= o.first + o.count) break;
    std::istringstream fields(line);
    core::Mat4 P = core::Mat4::Identity();
    int n = 0;
    double v;
    while (fields >> v) {
      if (n < 12) P(n / 4, n % 4) = v;
      ++n;
      if (!std::isfinite(v)) return makeError(o.file, ":", number, ": not a finite number");
    }
    if (!fields.eof() || n != 12) {
      return makeError(o.file, ":", number, ": expected 12 numbers (a 3x4 pose), got ", n,
                       fields.eof() ? "" : " and text");
    }
    const double det = P.topLeftCorner<3, 3>().determinant();
    if (std::abs(det - 1.0) > 1e-3) {
      return makeError(o.file, ":", number, ": rotation has determinant ", det, ", not 1");
    }
    utimes.push_back(start_utime + std::llround((frame - o.first) * period_us));
    poses.push_back(body_T_cam * SE3d::fromMatrix(P) * cam_T_body);
  }
  if (poses.size() < 2) return makeError(o.file, ": fewer than 2 poses in the selected range");
  SessionPlan plan;
  plan.index = 0;
  auto trajectory = std::make_shared<SampledTrajectory>(std::move(utimes), poses);
  plan.distance_m = trajectory->at(trajectory->endUtime()).odometer_m;
  plan.trajectory = std::move(trajectory);
  plan.floors_visited = {0};
  return plan;
}

}  // namespace evermap::sim
