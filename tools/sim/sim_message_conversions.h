#pragma once
// Small conversions between evermap LCM messages and geometry types, private to the
// simulator: core/messages/convert.h has no conversions yet for vo_delta_t,
// register_result_t and keyframe_t; once it has, these should move there. GROUND_TRUTH uses
// convert.h's pose_t conversion.

#include <cstdint>

#include <evermap/keyframe_t.hpp>
#include <evermap/pose_t.hpp>
#include <evermap/register_result_t.hpp>
#include <evermap/vo_delta_t.hpp>

#include "core/geometry/se3.h"
#include "tools/sim/sensors.h"

namespace evermap::sim {

// Writes a pose as translation[3] + quaternion w x y z.
void writePose(const core::SE3d& pose, double translation[3], double orientation_wxyz[4]);
core::SE3d readPose(const double translation[3], const double orientation_wxyz[4]);
void writeCovariance(const core::Mat6& covariance, double out[36]);
core::Mat6 readCovariance(const double in[36]);

// GROUND_TRUTH: world_T_body, zero covariance.
pose_t toPoseMessage(int64_t utime, const core::SE3d& world_T_body, int floor, int session);
core::SE3d poseOf(const pose_t& m);
// ref_T_cur of a VO delta (meaningful when status is STATUS_OK).
core::SE3d deltaOf(const vo_delta_t& m);
// node_T_query of a registration result.
core::SE3d relativePoseOf(const register_result_t& m);

// A KEYFRAME without features: the keyframe's identity (utime) and the nominal intrinsics.
keyframe_t keyframeIdentity(int64_t utime, const CameraOptions& camera);

}  // namespace evermap::sim
