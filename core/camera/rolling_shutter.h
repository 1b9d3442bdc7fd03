#pragma once
// A rolling shutter: the rows of an image are exposed one after another, row v at
//   t(v) = t_mid + (v - cy) * line_delay_s,
// t_mid the instant of the principal point's row. A camera turning at omega (rad/s, in its own
// frame) sees a point at row v from the orientation it has at t(v), not at t_mid: at 60 deg/s
// and 40 us per row, the rows 240 apart of a Kinect's 640x480 frame are 0.6 deg apart, 5 px.
// One rigid motion between two frames cannot fit that; it leaves a share of it in the
// translation. Moving every feature to where the camera at t_mid sees it makes the frame a
// global-shutter one for everything downstream (registration, keyframes, loop closure).
//
// The correction is the rotation alone: the camera's translation during a readout (a few
// millimetres at walking speed) is left out. The row a feature is seen at is the row it was
// exposed at, so with the right omega and delay the correction is exact. With omega = 0 or
// line_delay_s = 0 it is the identity.

#include <optional>

#include <Eigen/Core>

#include "core/camera/stereo_camera.h"

namespace evermap::core {

// (u, v, d) of the point seen at (u, v, d) from the orientation the camera has at the middle
// row's instant; nullopt when the point does not back-project or leaves the front of the camera.
// `omega`: the camera's angular velocity in its own frame (rad/s).
std::optional<Eigen::Vector3d> toMiddleRow(const StereoCamera& camera, const Eigen::Vector3d& uvd,
                                           const Eigen::Vector3d& omega, double line_delay_s);

}  // namespace evermap::core
