#include "core/camera/rolling_shutter.h"

#include "core/geometry/so3.h"

namespace evermap::core {

std::optional<Eigen::Vector3d> toMiddleRow(const StereoCamera& camera, const Eigen::Vector3d& uvd,
                                           const Eigen::Vector3d& omega, double line_delay_s) {
  if (line_delay_s == 0.0 || omega.isZero()) return uvd;
  const auto p = camera.backProject(uvd);
  if (!p) return std::nullopt;
  // The camera at t(v) is the one at t_mid turned by exp(omega (t(v) - t_mid)) (on the right):
  // a point's coordinates go from the first to the second by that rotation.
  const double dt = (uvd.y() - camera.cy()) * line_delay_s;
  return camera.project(SO3d::exp(omega * dt) * *p);
}

}  // namespace evermap::core
