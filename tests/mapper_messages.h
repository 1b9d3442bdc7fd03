#pragma once
// Messages for the mapper tests: planar poses, VO deltas as vo-proc sends them, FLOOR as
// elevator-proc does.

#include <cstdint>

#include <evermap/attitude_t.hpp>
#include <evermap/floor_t.hpp>
#include <evermap/vo_delta_t.hpp>
#include <evermap/wheel_odom_t.hpp>

#include "core/geometry/se3.h"
#include "core/messages/pose_fields.h"

namespace evermap::mapper::testing {

// The names the mapper tests write (`using namespace testing;` in each).
using core::Mat6;
using core::SE3d;
using core::UncertainPose;
using core::Vec3;
using core::Vec6;

inline SE3d planar(double x, double y, double yaw) {
  return SE3d(core::SO3d::exp(Vec3(0, 0, yaw)), Vec3(x, y, 0));
}

inline vo_delta_t voMsg(int64_t utime, int64_t ref, const SE3d& ref_T_cur, double sigma,
                        bool keyframe) {
  vo_delta_t m{};
  m.utime = utime;
  m.ref_utime = ref;
  m.status = vo_delta_t::STATUS_OK;
  m.keyframe_changed = keyframe ? 1 : 0;
  messages::putPose(ref_T_cur, m.translation, m.orientation);
  for (int i = 0; i < 6; ++i) m.covariance[7 * i] = sigma * sigma;
  return m;
}

// A FLOOR message as elevator-proc sends it (height sigma 0.05 m; in the cab from a ride's
// start on).
inline floor_t floorMsg(int64_t utime, int8_t event, double height_m, int32_t index) {
  floor_t f{};
  f.utime = utime;
  f.event = event;
  f.height_m = height_m;
  f.height_sigma_m = 0.05;
  f.floor_index = index;
  f.in_elevator = event == floor_t::EVENT_RIDE_START ? 1 : 0;
  return f;
}

// A WHEEL_ODOM increment straight ahead, each of x, y, θ with `variance`.
inline wheel_odom_t wheelMsg(int64_t prev, int64_t utime, double dx, double variance = 1e-4) {
  wheel_odom_t w{};
  w.prev_utime = prev;
  w.utime = utime;
  w.delta_x_m = dx;
  w.covariance[0] = w.covariance[4] = w.covariance[8] = variance;
  return w;
}

// ATTITUDE as imu-proc sends it: the gyro's heading, its bias sigma left (rad/s) and its
// integration's epoch; roll and pitch 0, trusted.
inline attitude_t heading(int64_t utime, double heading_rad, double rate_sigma = 1e-4,
                          int64_t epoch = 0) {
  attitude_t a{};
  a.heading_epoch = epoch;
  a.utime = utime;
  a.covariance[0] = a.covariance[3] = 1e-6;
  a.accel_trusted = 1;
  a.heading_rad = heading_rad;
  a.heading_rate_sigma_rad_s = rate_sigma;
  a.heading_valid = 1;
  return a;
}

inline vo_delta_t voRestart(int64_t utime) {
  vo_delta_t m = voMsg(utime, utime, SE3d(), 0.0, true);
  m.status = vo_delta_t::STATUS_NO_DATA;
  return m;
}

}  // namespace evermap::mapper::testing
