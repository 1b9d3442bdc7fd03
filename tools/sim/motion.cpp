#include "tools/sim/motion.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <numbers>

namespace evermap::sim {
namespace {

constexpr double kTwoPi = 2.0 * std::numbers::pi;

void requireInRange(int64_t utime, int64_t start, int64_t end) {
  if (utime < start || utime > end) {
    std::fprintf(stderr, "evermap::sim: trajectory queried at %lld outside [%lld, %lld]\n",
                 static_cast<long long>(utime), static_cast<long long>(start),
                 static_cast<long long>(end));
    std::abort();
  }
}

}  // namespace

MotionProfile::MotionProfile(Shape shape, double distance, double speed, double accel)
    : shape_(shape), distance_(std::abs(distance)), speed_(speed), accel_(accel) {
  if (distance_ <= 0.0 || speed <= 0.0 || accel <= 0.0) {
    speed_ = 0.0;
    return;
  }
  // Distance covered by one ramp from rest to v: trapezoid v^2 / (2a); smooth ramp v^2 / a
  // (the ramp lasts 2v/a because the mean acceleration is a/2).
  const double ramp_factor = shape_ == Shape::kTrapezoid ? 0.5 : 1.0;
  if (2.0 * ramp_factor * speed_ * speed_ / accel_ > distance_) {
    speed_ = std::sqrt(distance_ * accel_ / (2.0 * ramp_factor));
  }
  ramp_s_ = (shape_ == Shape::kTrapezoid ? 1.0 : 2.0) * speed_ / accel_;
  const double ramp_distance = ramp_factor * speed_ * speed_ / accel_;
  cruise_s_ = std::max(0.0, (distance_ - 2.0 * ramp_distance) / speed_);
}

double MotionProfile::rampPosition(double t) const {
  if (shape_ == Shape::kTrapezoid) return 0.5 * accel_ * t * t;
  const double k = ramp_s_ / kTwoPi;
  return 0.5 * accel_ * (0.5 * t * t + k * k * (std::cos(t / k) - 1.0));
}

double MotionProfile::rampVelocity(double t) const {
  if (shape_ == Shape::kTrapezoid) return accel_ * t;
  const double k = ramp_s_ / kTwoPi;
  return 0.5 * accel_ * (t - k * std::sin(t / k));
}

double MotionProfile::rampAcceleration(double t) const {
  if (shape_ == Shape::kTrapezoid) return accel_;
  return 0.5 * accel_ * (1.0 - std::cos(kTwoPi * t / ramp_s_));
}

double MotionProfile::position(double t) const {
  if (speed_ <= 0.0 || t <= 0.0) return 0.0;
  const double total = duration();
  if (t >= total) return distance_;
  if (t < ramp_s_) return rampPosition(t);
  if (t <= ramp_s_ + cruise_s_) return rampPosition(ramp_s_) + speed_ * (t - ramp_s_);
  return distance_ - rampPosition(total - t);
}

double MotionProfile::velocity(double t) const {
  if (speed_ <= 0.0 || t <= 0.0 || t >= duration()) return 0.0;
  if (t < ramp_s_) return rampVelocity(t);
  if (t <= ramp_s_ + cruise_s_) return speed_;
  return rampVelocity(duration() - t);
}

double MotionProfile::acceleration(double t) const {
  if (speed_ <= 0.0 || t <= 0.0 || t >= duration()) return 0.0;
  if (t < ramp_s_) return rampAcceleration(t);
  if (t <= ramp_s_ + cruise_s_) return 0.0;
  return -rampAcceleration(duration() - t);
}

double FloorRoughness::roll(double odometer_m) const {
  return amplitude_rad * std::sin(kTwoPi * odometer_m / roll_wavelength_m);
}

double FloorRoughness::pitch(double odometer_m) const {
  return amplitude_rad * std::sin(kTwoPi * odometer_m / pitch_wavelength_m + 1.0);
}

SegmentTrajectory::SegmentTrajectory(int64_t start_utime, std::vector<Segment> segments,
                                     FloorRoughness roughness)
    : start_utime_(start_utime), segments_(std::move(segments)), roughness_(roughness) {
  if (segments_.empty()) {
    std::fprintf(stderr, "evermap::sim: a trajectory needs at least one segment\n");
    std::abort();
  }
  const Segment& last = segments_.back();
  end_utime_ = start_utime_ + static_cast<int64_t>(std::floor((last.t0_s + last.duration_s) * 1e6));
}

BodyState SegmentTrajectory::at(int64_t utime) const {
  requireInRange(utime, start_utime_, end_utime_);
  const double t = static_cast<double>(utime - start_utime_) * 1e-6;
  auto it = std::upper_bound(segments_.begin(), segments_.end(), t,
                             [](double v, const Segment& s) { return v < s.t0_s; });
  const Segment& s = it == segments_.begin() ? *it : *(it - 1);
  const double tau = std::clamp(t - s.t0_s, 0.0, s.duration_s);
  BodyState b;
  Vec2 xy = s.from;
  double yaw = s.yaw0;
  double z = s.z0;
  b.odometer_m = s.odometer0_m;
  b.floor = s.floor;
  b.in_cab = s.in_cab;
  switch (s.kind) {
    case Segment::Kind::kDrive: {
      const Vec2 dir = (s.to - s.from).normalized();
      const double d = s.profile.position(tau);
      xy = s.from + d * dir;
      b.odometer_m += d;
      b.velocity_world.head<2>() = s.profile.velocity(tau) * dir;
      b.acceleration_world.head<2>() = s.profile.acceleration(tau) * dir;
      break;
    }
    case Segment::Kind::kTurn:
      yaw = s.yaw0 + std::copysign(s.profile.position(tau), s.yaw1 - s.yaw0);
      b.blank_wall_turn = s.blank_wall;
      break;
    case Segment::Kind::kWait:
      break;
    case Segment::Kind::kRide: {
      const double sign = s.z1 >= s.z0 ? 1.0 : -1.0;
      z = s.z0 + sign * s.profile.position(tau);
      b.velocity_world.z() = sign * s.profile.velocity(tau);
      b.acceleration_world.z() = sign * s.profile.acceleration(tau);
      b.riding = tau > 0.0 && tau < s.duration_s;
      if (tau >= s.duration_s)
        b.floor = s.floor_to;
      else if (tau > 0.0)
        b.floor = -1;
      break;
    }
  }
  const double roll = roughness_.roll(b.odometer_m);
  const double pitch = roughness_.pitch(b.odometer_m);
  b.world_T_body = SE3d(core::SO3d::fromRollPitchYaw(roll, pitch, yaw), Vec3(xy.x(), xy.y(), z));
  return b;
}

SampledTrajectory::SampledTrajectory(std::vector<int64_t> utimes, std::vector<SE3d> world_T_body)
    : utimes_(std::move(utimes)), poses_(std::move(world_T_body)) {
  bool ok = utimes_.size() >= 2 && utimes_.size() == poses_.size();
  for (size_t i = 1; ok && i < utimes_.size(); ++i) ok = utimes_[i] > utimes_[i - 1];
  if (!ok) {
    std::fprintf(stderr,
                 "evermap::sim: a sampled trajectory needs >= 2 poses at increasing times\n");
    std::abort();
  }
  odometer_.resize(poses_.size(), 0.0);
  for (size_t i = 1; i < poses_.size(); ++i) {
    odometer_[i] =
        odometer_[i - 1] + (poses_[i].translation() - poses_[i - 1].translation()).norm();
  }
}

Vec3 SampledTrajectory::velocityOfInterval(size_t i) const {
  const double dt = static_cast<double>(utimes_[i + 1] - utimes_[i]) * 1e-6;
  return (poses_[i + 1].translation() - poses_[i].translation()) / dt;
}

BodyState SampledTrajectory::at(int64_t utime) const {
  requireInRange(utime, utimes_.front(), utimes_.back());
  auto it = std::upper_bound(utimes_.begin(), utimes_.end(), utime);
  size_t i = static_cast<size_t>(it - utimes_.begin()) - 1;
  if (i + 1 >= utimes_.size()) i = utimes_.size() - 2;
  BodyState b;
  b.floor = 0;
  const double alpha =
      static_cast<double>(utime - utimes_[i]) / static_cast<double>(utimes_[i + 1] - utimes_[i]);
  if (alpha == 0.0) {
    b.world_T_body = poses_[i];
    b.odometer_m = odometer_[i];
  } else {
    const Vec3 p = (1.0 - alpha) * poses_[i].translation() + alpha * poses_[i + 1].translation();
    const Eigen::Quaterniond q = poses_[i].quaternion().slerp(alpha, poses_[i + 1].quaternion());
    b.world_T_body = SE3d(q, p);
    b.odometer_m = odometer_[i] + alpha * (odometer_[i + 1] - odometer_[i]);
  }
  b.velocity_world = velocityOfInterval(i);
  if (i > 0) {
    const double dt = static_cast<double>(utimes_[i + 1] - utimes_[i - 1]) * 0.5e-6;
    b.acceleration_world = (velocityOfInterval(i) - velocityOfInterval(i - 1)) / dt;
  }
  return b;
}

}  // namespace evermap::sim
