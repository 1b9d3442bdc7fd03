#pragma once
// Turns one planned session into the messages the robot's processes would publish, in time
// order: GROUND_TRUTH, IMU (around elevator rides), WHEEL_ODOM, ATTITUDE, FLOOR, VO_DELTA and
// KEYFRAME. Each stream runs at its own fixed rate from the session's start; ties at one
// instant go out in that order.
//
// KEYFRAME messages are identities only: a keyframe_t with the keyframe's utime and the
// nominal camera intrinsics, num_features = 0 (the measurement-level simulator has no image
// features; the registration oracle answers from ground truth instead). One is published for
// every VO frame that became a reference keyframe (keyframe_changed = 1), just after its
// VO_DELTA.

#include <array>
#include <cstdint>
#include <functional>
#include <vector>

#include "tools/sim/building.h"
#include "tools/sim/message_sink.h"
#include "tools/sim/patrol.h"
#include "tools/sim/sensors.h"

namespace evermap::sim {

struct SensorOptions {
  CameraOptions camera;
  VoOptions vo;
  WheelOptions wheel;
  AttitudeOptions attitude;
  FloorOptions floor;
  ImuOptions imu;
  double ground_truth_rate_hz = 10.0;

  // Messages start with the section name ("vo.rate_hz: must be > 0").
  Status validate() const;
};

// Ground truth of one keyframe, for the registration oracle.
struct KeyframeTruth {
  int64_t utime = 0;
  SE3d world_T_cam;
  int floor = -1;
  int session = -1;
};

struct SessionObservers {
  std::function<void(const KeyframeTruth&)> on_keyframe;
  std::function<void(int64_t utime, const BodyState&)> on_ground_truth;
};

// A stretch of uninterrupted visual odometry: the keyframe deltas chained from a (re)start to
// the last keyframe before a failure, against ground truth.
struct VoChain {
  double length_m = 0.0;  // distance driven along the chain
  double error_m = 0.0;   // position error of the chained estimate at its end
};

struct SessionSummary {
  int session = 0;
  int64_t start_utime = 0;
  int64_t end_utime = 0;
  double distance_m = 0.0;
  int rides = 0;
  std::vector<int> floors_visited;
  int64_t vo_frames = 0;
  int64_t vo_keyframes = 0;            // frames with keyframe_changed = 1
  std::array<int64_t, 7> vo_status{};  // frames per vo_delta_t status
  std::vector<VoChain> vo_chains;
  int64_t passerby_events = 0;
  int64_t slip_events = 0;

  double durationS() const { return static_cast<double>(end_utime - start_utime) * 1e-6; }
  int64_t voFailed() const;  // frames with a failure status
};

// Generates one session. `seed` is the run's seed; the session's noise streams derive from it
// and the session index, so sessions can be generated in any order with the same result.
SessionSummary generateSession(const Building& building, const SessionPlan& plan,
                               const SensorOptions& options, uint64_t seed, MessageSink& sink,
                               const SessionObservers& observers = {});

}  // namespace evermap::sim
