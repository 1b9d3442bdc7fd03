#pragma once
// Ground-truth robot motion: a trajectory is a function of time giving the body pose, its
// velocity and acceleration, and the facts the sensor models need (floor, inside the elevator
// cab, turning towards a blank wall).
//
// Body frame: x forward, y left, z up, origin on the floor surface between the wheels.
// World frame: z up, floor 0 at z = 0, the elevator shaft on the z axis.

#include <cstdint>
#include <vector>

#include "core/geometry/se2.h"
#include "core/geometry/se3.h"

namespace evermap::sim {

using core::SE3d;
using core::Vec2;
using core::Vec3;

struct BodyState {
  SE3d world_T_body;
  Vec3 velocity_world = Vec3::Zero();      // m/s
  Vec3 acceleration_world = Vec3::Zero();  // m/s^2, without gravity
  double odometer_m = 0.0;                 // distance driven since the session started
  int floor = -1;                          // floor index; -1 while the cab moves between floors
  bool in_cab = false;                     // inside the elevator cab
  bool riding = false;                     // the cab is moving
  bool blank_wall_turn = false;            // turning in place while facing a featureless wall
};

class Trajectory {
 public:
  virtual ~Trajectory() = default;
  virtual int64_t startUtime() const = 0;
  virtual int64_t endUtime() const = 0;
  // Contract: startUtime() <= utime <= endUtime().
  virtual BodyState at(int64_t utime) const = 0;
};

// A one-dimensional move of `distance` from rest to rest. Trapezoid: constant acceleration
// `accel` up to `speed`, cruise, constant deceleration (a triangle when too short to reach
// `speed`). Smooth: the acceleration rises and falls as 1 - cos over each ramp (peak `accel`,
// mean accel/2), the jerk-limited shape of an elevator; same cruise logic.
class MotionProfile {
 public:
  enum class Shape { kTrapezoid, kSmooth };
  MotionProfile() = default;
  MotionProfile(Shape shape, double distance, double speed, double accel);

  double duration() const { return 2.0 * ramp_s_ + cruise_s_; }
  double position(double t) const;
  double velocity(double t) const;
  double acceleration(double t) const;
  double peakSpeed() const { return speed_; }

 private:
  double rampPosition(double t) const;
  double rampVelocity(double t) const;
  double rampAcceleration(double t) const;

  Shape shape_ = Shape::kTrapezoid;
  double distance_ = 0.0;
  double speed_ = 0.0;
  double accel_ = 0.0;
  double ramp_s_ = 0.0;
  double cruise_s_ = 0.0;
};

// One piece of a planned motion.
struct Segment {
  enum class Kind { kDrive, kTurn, kWait, kRide };
  Kind kind = Kind::kWait;
  double t0_s = 0.0;  // start, seconds since the session started
  double duration_s = 0.0;
  int floor = 0;             // kRide: departure floor
  int floor_to = 0;          // kRide: arrival floor
  Vec2 from = Vec2::Zero();  // position (kDrive: start)
  Vec2 to = Vec2::Zero();    // kDrive: end
  double yaw0 = 0.0;         // heading at the start (kTurn: unwrapped start)
  double yaw1 = 0.0;         // kTurn: unwrapped end heading
  double z0 = 0.0;           // floor surface height (kRide: departure)
  double z1 = 0.0;           // kRide: arrival height
  double odometer0_m = 0.0;  // distance driven before this segment
  MotionProfile profile;     // kDrive (metres), kTurn (radians), kRide (metres)
  bool in_cab = false;
  bool blank_wall = false;  // kTurn: facing a featureless wall
};

// The small roll and pitch of a robot on a real floor, as functions of distance driven (so
// they stay constant while the robot stands, in particular in the elevator).
struct FloorRoughness {
  double amplitude_rad = 0.005;
  double roll_wavelength_m = 3.7;
  double pitch_wavelength_m = 5.3;
  double roll(double odometer_m) const;
  double pitch(double odometer_m) const;
};

class SegmentTrajectory final : public Trajectory {
 public:
  SegmentTrajectory(int64_t start_utime, std::vector<Segment> segments, FloorRoughness roughness);
  int64_t startUtime() const override { return start_utime_; }
  int64_t endUtime() const override { return end_utime_; }
  BodyState at(int64_t utime) const override;
  const std::vector<Segment>& segments() const { return segments_; }

 private:
  int64_t start_utime_;
  int64_t end_utime_;
  std::vector<Segment> segments_;
  FloorRoughness roughness_;
};

// Poses sampled at given times (a recorded trajectory), interpolated linearly in position and
// by slerp in rotation; velocity and acceleration by finite differences. One floor (0).
class SampledTrajectory final : public Trajectory {
 public:
  // Contract: at least two samples, strictly increasing times.
  SampledTrajectory(std::vector<int64_t> utimes, std::vector<SE3d> world_T_body);
  int64_t startUtime() const override { return utimes_.front(); }
  int64_t endUtime() const override { return utimes_.back(); }
  BodyState at(int64_t utime) const override;
  size_t size() const { return utimes_.size(); }

 private:
  Vec3 velocityOfInterval(size_t i) const;  // between samples i and i + 1
  std::vector<int64_t> utimes_;
  std::vector<SE3d> poses_;
  std::vector<double> odometer_;
};

}  // namespace evermap::sim
