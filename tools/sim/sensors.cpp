#include "tools/sim/sensors.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <numbers>
#include <string>

#include "core/camera/pinhole.h"
#include "core/geometry/se2.h"
#include "core/messages/pose_fields.h"
#include "tools/sim/streams.h"

namespace evermap::sim {
namespace {

void setDiagonal6(double* cov, double sigma_t, double sigma_r) {
  std::fill(cov, cov + 36, 0.0);
  for (int i = 0; i < 3; ++i) {
    cov[i * 7] = sigma_t * sigma_t;
    cov[(i + 3) * 7] = sigma_r * sigma_r;
  }
}

std::string shortest(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

Status positive(double v, const char* name) {
  if (!(v > 0.0)) return makeError(name, ": must be > 0, got ", shortest(v));
  return Ok{};
}

Status nonNegative(std::initializer_list<double> values, const char* name) {
  for (double v : values) {
    if (!(v >= 0.0))
      return makeError(name, ": noise and rate parameters must be >= 0, got ", shortest(v));
  }
  return Ok{};
}

}  // namespace

SE3d CameraOptions::bodyTCam() const {
  core::Mat3 R;
  // Columns: the camera's x (right), y (down), z (forward) axes in the body frame.
  R << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  return SE3d(core::SO3d::fromMatrix(R), Vec3(forward_m, 0.0, height_m));
}

core::StereoCalibration CameraOptions::stereoCalibration(int width, int height) const {
  core::CameraCalibration left = core::pinholeCamera(width, height, fx, fy, cx, cy);
  left.body_T_cam = bodyTCam();
  return core::rectifiedPair(left, baseline_m);
}

Status CameraOptions::validate() const {
  for (double v : {height_m, forward_m}) {
    if (!std::isfinite(v)) return makeError("height_m: camera offsets must be finite");
  }
  if (!(fx > 0.0 && fy > 0.0 && cx > 0.0 && cy > 0.0))
    return makeError("fx: intrinsics must be > 0");
  return positive(baseline_m, "baseline_m");
}

Status VoOptions::validate() const {
  if (auto s = positive(rate_hz, "rate_hz"); !s) return s;
  if (auto s =
          nonNegative({keyframe_translation_m, keyframe_rotation_rad}, "keyframe_translation_m");
      !s)
    return s;
  if (auto s = nonNegative({translation_sigma_m, translation_sigma_per_m, translation_sigma_per_rad,
                            rotation_sigma_rad, rotation_sigma_per_rad, rotation_sigma_per_m},
                           "translation_sigma_m");
      !s) {
    return s;
  }
  if (auto s = nonNegative({passerby_rate_per_hour, passerby_min_s}, "passerby_rate_per_hour"); !s)
    return s;
  if (!(passerby_max_s >= passerby_min_s))
    return makeError("passerby_max_s: must be >= passerby_min_s");
  return Ok{};
}

Status WheelOptions::validate() const {
  if (auto s = positive(rate_hz, "rate_hz"); !s) return s;
  if (auto s = nonNegative({sigma_m, sigma_rad, sigma_forward_per_m, sigma_lateral_per_m,
                            sigma_theta_per_m, sigma_theta_per_rad},
                           "sigma_m");
      !s) {
    return s;
  }
  if (auto s = nonNegative({slip_rate_per_hour, slip_min_s, slip_min_fraction, slip_yaw_rad_per_m},
                           "slip_rate_per_hour");
      !s) {
    return s;
  }
  if (!(slip_max_s >= slip_min_s)) return makeError("slip_max_s: must be >= slip_min_s");
  if (!(slip_max_fraction >= slip_min_fraction && slip_max_fraction < 1.0)) {
    return makeError("slip_max_fraction: must be in [slip_min_fraction, 1)");
  }
  return Ok{};
}

Status AttitudeOptions::validate() const {
  if (auto s = positive(rate_hz, "rate_hz"); !s) return s;
  if (auto s = nonNegative({sigma_rad}, "sigma_rad"); !s) return s;
  if (auto s = positive(untrusted_accel_mps2, "untrusted_accel_mps2"); !s) return s;
  if (auto s = nonNegative({heading_noise_density, heading_bias_sigma_rad_s,
                            heading_bias_walk_density, heading_scale_sigma},
                           "heading_noise_density");
      !s)
    return s;
  return positive(heading_still_s, "heading_still_s");
}

Status FloorOptions::validate() const {
  if (auto s = nonNegative({height_sigma_m, height_sigma_per_m}, "height_sigma_m"); !s) return s;
  return positive(match_threshold_m, "match_threshold_m");
}

Status ImuOptions::validate() const {
  if (auto s = positive(rate_hz, "rate_hz"); !s) return s;
  if (auto s = nonNegative({margin_s}, "margin_s"); !s) return s;
  if (auto s = nonNegative(
          {accel_sigma_mps2, gyro_sigma_radps, gyro_bias_sigma_radps, accel_bias_sigma_mps2},
          "accel_sigma_mps2");
      !s) {
    return s;
  }
  return positive(gravity_mps2, "gravity_mps2");
}

Intervals::Intervals(int64_t start, int64_t end, double rate_per_hour, double min_s, double max_s,
                     Random& rng) {
  if (rate_per_hour <= 0.0) return;
  const double mean_gap_s = 3600.0 / rate_per_hour;
  double t = static_cast<double>(start);
  while (true) {
    t += rng.exponential(mean_gap_s) * 1e6;
    if (t >= static_cast<double>(end)) break;
    const auto b = static_cast<int64_t>(t);
    const auto e = b + static_cast<int64_t>(rng.uniform(min_s, max_s) * 1e6);
    spans_.emplace_back(b, e);
    t = static_cast<double>(e);  // events do not overlap
  }
}

bool Intervals::contains(int64_t utime) const {
  auto it = std::upper_bound(spans_.begin(), spans_.end(), std::make_pair(utime, INT64_MAX));
  if (it == spans_.begin()) return false;
  --it;
  return utime >= it->first && utime < it->second;
}

VoModel::VoModel(const VoOptions& options, const SE3d& body_T_cam, Random rng)
    : o_(options), body_T_cam_(body_T_cam), rng_(rng) {}

vo_delta_t VoModel::frame(int64_t utime, const BodyState& state, int8_t condition) {
  vo_delta_t m = measure(utime, state, condition);
  odometry_frame_.stamp(m);
  return m;
}

vo_delta_t VoModel::measure(int64_t utime, const BodyState& state, int8_t condition) {
  vo_delta_t m{};
  m.utime = utime;
  m.orientation[0] = 1.0;
  const SE3d world_T_cam = state.world_T_body * body_T_cam_;
  if (condition != vo_delta_t::STATUS_OK) {
    // Lost: no motion estimate; the next good frame starts over from a new keyframe.
    tracking_ = false;
    m.status = condition;
    m.ref_utime = ref_utime_ != 0 ? ref_utime_ : utime;
    if (condition == vo_delta_t::STATUS_INSUFFICIENT_FEATURES) {
      m.num_features = static_cast<int32_t>(rng_.integer(0, 40));
    } else {
      m.num_features = static_cast<int32_t>(rng_.integer(150, 500));
      m.num_matches = static_cast<int32_t>(rng_.integer(10, 60));
      m.num_inliers = static_cast<int32_t>(rng_.integer(0, 9));
    }
    return m;
  }
  m.num_features = static_cast<int32_t>(rng_.integer(300, 600));
  m.num_matches = static_cast<int32_t>(m.num_features * rng_.uniform(0.5, 0.7));
  m.num_inliers = static_cast<int32_t>(m.num_matches * rng_.uniform(0.6, 0.9));
  if (!tracking_) {
    tracking_ = true;
    ref_utime_ = utime;
    world_T_ref_ = world_T_cam;
    m.status = vo_delta_t::STATUS_NO_DATA;
    m.ref_utime = utime;
    m.keyframe_changed = 1;
    m.num_matches = 0;
    m.num_inliers = 0;
    return m;
  }
  const SE3d ref_T_cur = world_T_ref_.inverse() * world_T_cam;
  const double d = ref_T_cur.translation().norm();
  const double theta = core::rotationAngle(ref_T_cur.so3());
  const double st = o_.translation_sigma_m + o_.translation_sigma_per_m * d +
                    o_.translation_sigma_per_rad * theta;
  const double sr =
      o_.rotation_sigma_rad + o_.rotation_sigma_per_rad * theta + o_.rotation_sigma_per_m * d;
  core::Vec6 delta;
  for (int i = 0; i < 3; ++i) delta[i] = st * rng_.normal();
  for (int i = 3; i < 6; ++i) delta[i] = sr * rng_.normal();
  const SE3d measured = (st > 0.0 || sr > 0.0) ? ref_T_cur * SE3d::exp(delta) : ref_T_cur;
  m.status = vo_delta_t::STATUS_OK;
  m.ref_utime = ref_utime_;
  messages::putPose(measured, m.translation, m.orientation);
  setDiagonal6(m.covariance, st, sr);
  if (d >= o_.keyframe_translation_m || theta >= o_.keyframe_rotation_rad) {
    m.keyframe_changed = 1;
    ref_utime_ = utime;
    world_T_ref_ = world_T_cam;
  }
  return m;
}

WheelModel::WheelModel(const WheelOptions& options, Intervals slips, Random rng)
    : o_(options), slips_(std::move(slips)), rng_(rng) {}

wheel_odom_t WheelModel::increment(int64_t prev_utime, const BodyState& prev, int64_t utime,
                                   const BodyState& cur) {
  const core::SE2d a = core::toPlanar(prev.world_T_body);
  const core::SE2d b = core::toPlanar(cur.world_T_body);
  const core::SE2d delta = core::between(a, b);
  const double d = delta.translation().norm();
  const double dtheta = std::abs(delta.theta());
  const double sx = o_.sigma_m + o_.sigma_forward_per_m * d;
  const double sy = o_.sigma_m + o_.sigma_lateral_per_m * d;
  const double st = o_.sigma_rad + o_.sigma_theta_per_m * d + o_.sigma_theta_per_rad * dtheta;
  double dx = delta.x();
  double dy = delta.y();
  double dt = delta.theta();
  if (slips_.contains(utime)) {
    const double f = rng_.uniform(o_.slip_min_fraction, o_.slip_max_fraction);
    dx *= 1.0 + f;
    dy *= 1.0 + f;
    dt += (rng_.bernoulli(0.5) ? 1.0 : -1.0) * o_.slip_yaw_rad_per_m * d;
  }
  wheel_odom_t m{};
  m.utime = utime;
  m.prev_utime = prev_utime;
  m.delta_x_m = dx + (sx > 0.0 ? sx * rng_.normal() : 0.0);
  m.delta_y_m = dy + (sy > 0.0 ? sy * rng_.normal() : 0.0);
  m.delta_theta_rad = dt + (st > 0.0 ? st * rng_.normal() : 0.0);
  m.covariance[0] = sx * sx;
  m.covariance[4] = sy * sy;
  m.covariance[8] = st * st;
  odometry_frame_.stamp(m);
  return m;
}

attitude_t measureAttitude(int64_t utime, const BodyState& state, const AttitudeOptions& o,
                           Random& rng) {
  const Vec3 rpy = state.world_T_body.so3().rollPitchYaw();
  attitude_t m{};
  m.utime = utime;
  m.roll_rad = rpy.x() + (o.sigma_rad > 0.0 ? o.sigma_rad * rng.normal() : 0.0);
  m.pitch_rad = rpy.y() + (o.sigma_rad > 0.0 ? o.sigma_rad * rng.normal() : 0.0);
  m.covariance[0] = o.sigma_rad * o.sigma_rad;
  m.covariance[3] = o.sigma_rad * o.sigma_rad;
  m.accel_trusted = state.acceleration_world.norm() < o.untrusted_accel_mps2 ? 1 : 0;
  return m;
}

GyroHeadingModel::GyroHeadingModel(const AttitudeOptions& options, Random rng)
    : o_(options), rng_(rng) {
  scale_error_ = o_.heading_scale_sigma * rng_.normal();
  // The robot stood still before its session (it boots standing): one zero-rate update.
  bias_error_ = o_.heading_bias_sigma_rad_s * rng_.normal();
  bias_variance_ = o_.heading_bias_sigma_rad_s * o_.heading_bias_sigma_rad_s;
}

void GyroHeadingModel::fill(int64_t utime, const BodyState& s, attitude_t* m) {
  const double yaw = s.world_T_body.so3().rollPitchYaw().z();
  if (last_utime_ >= 0 && utime > last_utime_) {
    const double dt = 1e-6 * static_cast<double>(utime - last_utime_);
    const double turned = std::remainder(yaw - last_yaw_, 2.0 * std::numbers::pi);
    unwrapped_yaw_ += turned;
    heading_error_ += bias_error_ * dt + scale_error_ * turned +
                      o_.heading_noise_density * std::sqrt(dt) * rng_.normal();
    const bool still = s.velocity_world.head<2>().norm() < 0.01 &&
                       s.acceleration_world.norm() < 0.1 && std::abs(turned) < 1e-3 * dt;
    still_s_ = still ? still_s_ + dt : 0.0;
    if (still_s_ >= o_.heading_still_s) {
      bias_error_ = o_.heading_bias_sigma_rad_s * rng_.normal();
      bias_variance_ = o_.heading_bias_sigma_rad_s * o_.heading_bias_sigma_rad_s;
      still_s_ = 0.0;
    } else {
      const double walk = o_.heading_bias_walk_density * std::sqrt(dt);
      bias_error_ += walk * rng_.normal();
      bias_variance_ += walk * walk;
    }
  } else if (last_utime_ < 0) {
    unwrapped_yaw_ = yaw;
    epoch_ = utime;  // one integration for the session
  }
  last_yaw_ = yaw;
  last_utime_ = utime;
  m->heading_rad = unwrapped_yaw_ + heading_error_;
  m->heading_rate_sigma_rad_s = std::sqrt(bias_variance_);
  m->heading_valid = 1;
  m->heading_epoch = epoch_;
}

std::vector<floor_t> floorEvents(const Building& building, const SessionPlan& plan,
                                 const FloorOptions& o, Random& rng) {
  std::vector<floor_t> out;
  const BodyState first = plan.trajectory->at(plan.trajectory->startUtime());
  // Session start: the operator tells elevator-proc where the robot starts (as in the paper's
  // experiment, "beginning and ending on floor 3").
  floor_t start{};
  start.utime = plan.trajectory->startUtime();
  start.floor_index = first.floor;
  start.height_m = building.floors[first.floor].height_m;
  start.event = floor_t::EVENT_NONE;
  out.push_back(start);
  double height = start.height_m;
  double sigma = 0.0;
  for (const ElevatorRide& r : plan.rides) {
    floor_t s{};
    s.utime = r.start_utime;
    s.floor_index = -1;
    s.height_m = height;
    s.height_sigma_m = sigma;
    s.in_elevator = 1;
    s.event = floor_t::EVENT_RIDE_START;
    out.push_back(s);
    const double dz = r.z_to - r.z_from;
    const double ride_sigma = o.height_sigma_m + o.height_sigma_per_m * std::abs(dz);
    const double measured = height + dz + (ride_sigma > 0.0 ? ride_sigma * rng.normal() : 0.0);
    sigma = std::sqrt(sigma * sigma + ride_sigma * ride_sigma);
    floor_t e{};
    e.utime = r.end_utime;
    e.height_m = measured;
    e.height_sigma_m = sigma;
    e.event = floor_t::EVENT_RIDE_END;
    const int nearest = building.nearestFloor(measured);
    if (std::abs(building.floors[nearest].height_m - measured) <= o.match_threshold_m) {
      e.floor_index = nearest;
      // The table holds the floor's height: the next ride integrates from there.
      height = building.floors[nearest].height_m;
      sigma = 0.0;
    } else {
      e.floor_index = -1;
      e.new_floor = 1;
      height = measured;
    }
    out.push_back(e);
  }
  return out;
}

Vec3 accelBias(const ImuOptions& o, Random& rng) {
  return Vec3(o.accel_bias_sigma_mps2 * rng.normal(), o.accel_bias_sigma_mps2 * rng.normal(),
              o.accel_bias_sigma_mps2 * rng.normal());
}

Vec3 gyroBias(const ImuOptions& o, uint64_t seed, int session) {
  Random rng = streamFor(seed, Stream::kGyroBias, session);
  const double s = o.gyro_bias_sigma_radps;
  return Vec3(s * rng.normal(), s * rng.normal(), s * rng.normal());
}

imu_t measureImu(int64_t utime, const Trajectory& trajectory, const ImuOptions& o, const Vec3& bias,
                 const Vec3& gyro_bias, Random& rng) {
  const BodyState s = trajectory.at(utime);
  const core::SO3d& R = s.world_T_body.so3();
  const Vec3 f = R.inverse() * (s.acceleration_world + Vec3(0.0, 0.0, o.gravity_mps2));
  // Body rates by a central difference of orientation over ±1 ms (clamped to the trajectory).
  const int64_t h = 1000;
  const int64_t t0 = std::max(trajectory.startUtime(), utime - h);
  const int64_t t1 = std::min(trajectory.endUtime(), utime + h);
  Vec3 w = Vec3::Zero();
  if (t1 > t0) {
    const core::SO3d R0 = trajectory.at(t0).world_T_body.so3();
    const core::SO3d R1 = trajectory.at(t1).world_T_body.so3();
    w = (R0.inverse() * R1).log() / (static_cast<double>(t1 - t0) * 1e-6);
  }
  imu_t m{};
  m.utime = utime;
  for (int i = 0; i < 3; ++i) {
    m.linear_acceleration[i] =
        f[i] + bias[i] + (o.accel_sigma_mps2 > 0.0 ? o.accel_sigma_mps2 * rng.normal() : 0.0);
    m.angular_velocity[i] =
        w[i] + gyro_bias[i] + (o.gyro_sigma_radps > 0.0 ? o.gyro_sigma_radps * rng.normal() : 0.0);
  }
  return m;
}

}  // namespace evermap::sim
