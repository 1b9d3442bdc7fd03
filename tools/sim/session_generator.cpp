#include "tools/sim/session_generator.h"

#include <cmath>
#include <limits>

#include <evermap/keyframe_t.hpp>
#include <evermap/pose_t.hpp>

#include "core/messages/channels.h"
#include "core/messages/convert.h"
#include "tools/sim/sim_message_conversions.h"
#include "tools/sim/streams.h"

namespace evermap::sim {
namespace {

constexpr int64_t kNever = std::numeric_limits<int64_t>::max();

// IMU ticks, only inside [ride start - margin, ride end + margin] windows.
class ImuSchedule {
 public:
  ImuSchedule(const SessionPlan& plan, const ImuOptions& o, int64_t start, int64_t end)
      : clock_(start, o.rate_hz) {
    if (!o.enabled) return;
    const auto margin = static_cast<int64_t>(o.margin_s * 1e6);
    for (const ElevatorRide& r : plan.rides) {
      const int64_t b = std::max(start, r.start_utime - margin);
      const int64_t e = std::min(end, r.end_utime + margin);
      if (!windows_.empty() && b <= windows_.back().second) {
        windows_.back().second = std::max(windows_.back().second, e);
      } else {
        windows_.emplace_back(b, e);
      }
    }
    settle();
  }
  int64_t next() const { return w_ < windows_.size() ? clock_.next() : kNever; }
  void advance() {
    clock_.advance();
    settle();
  }

 private:
  void settle() {
    while (w_ < windows_.size()) {
      if (clock_.next() < windows_[w_].first) clock_.skipTo(windows_[w_].first);
      if (clock_.next() <= windows_[w_].second) return;
      ++w_;
    }
  }
  TickClock clock_;
  std::vector<std::pair<int64_t, int64_t>> windows_;
  size_t w_ = 0;
};

int8_t visualCondition(const Building& building, const BodyState& s, const SE3d& body_T_cam,
                       const VoOptions& o, const Intervals& passers, int64_t utime) {
  if (o.fail_in_elevator && s.in_cab) return vo_delta_t::STATUS_INSUFFICIENT_FEATURES;
  if (o.fail_at_blank_walls && s.blank_wall_turn) return vo_delta_t::STATUS_INSUFFICIENT_FEATURES;
  if (o.fail_in_dark_rooms && s.floor >= 0) {
    const Floor& f = building.floors[s.floor];
    const Vec3 cam = (s.world_T_body * body_T_cam).translation();
    const int room = f.roomAt(cam.head<2>());
    if (room >= 0 && f.rooms[room].dark) return vo_delta_t::STATUS_INSUFFICIENT_FEATURES;
  }
  if (passers.contains(utime)) return vo_delta_t::STATUS_INSUFFICIENT_INLIERS;
  return vo_delta_t::STATUS_OK;
}

}  // namespace

Status SensorOptions::validate() const {
  const std::pair<const char*, Status> parts[] = {
      {"camera.", camera.validate()}, {"vo.", vo.validate()},
      {"wheel.", wheel.validate()},   {"attitude.", attitude.validate()},
      {"floor.", floor.validate()},   {"imu.", imu.validate()}};
  for (const auto& [prefix, status] : parts) {
    if (!status) return makeError(prefix, status.error().message);
  }
  if (!(ground_truth_rate_hz > 0.0)) return makeError("ground_truth.rate_hz: must be > 0");
  return Ok{};
}

int64_t SessionSummary::voFailed() const {
  int64_t n = 0;
  for (size_t s = 0; s < vo_status.size(); ++s) {
    if (s != vo_delta_t::STATUS_OK && s != vo_delta_t::STATUS_NO_DATA) n += vo_status[s];
  }
  return n;
}

SessionSummary generateSession(const Building& building, const SessionPlan& plan,
                               const SensorOptions& o, uint64_t seed, MessageSink& sink,
                               const SessionObservers& observers) {
  const Trajectory& traj = *plan.trajectory;
  const int64_t start = traj.startUtime();
  const int64_t end = traj.endUtime();
  const int session = plan.index;
  const SE3d body_T_cam = o.camera.bodyTCam();
  // The camera the VO deltas are of (DESIGN.md: calibration is state, repeated).
  const core::StereoCalibration calibration =
      o.camera.stereoCalibration(static_cast<int>(std::lround(2.0 * o.camera.cx)),
                                 static_cast<int>(std::lround(2.0 * o.camera.cy)));
  channels::CalibrationRepeat calib_repeat;

  Random passer_rng = streamFor(seed, Stream::kPassersBy, session);
  const Intervals passers(start, end, o.vo.passerby_rate_per_hour, o.vo.passerby_min_s,
                          o.vo.passerby_max_s, passer_rng);
  Random slip_rng = streamFor(seed, Stream::kSlips, session);
  Intervals slips(start, end, o.wheel.slip_rate_per_hour, o.wheel.slip_min_s, o.wheel.slip_max_s,
                  slip_rng);
  SessionSummary summary;
  summary.session = session;
  summary.start_utime = start;
  summary.end_utime = end;
  summary.distance_m = plan.distance_m;
  summary.rides = static_cast<int>(plan.rides.size());
  summary.floors_visited = plan.floors_visited;
  summary.passerby_events = static_cast<int64_t>(passers.size());
  summary.slip_events = static_cast<int64_t>(slips.size());

  VoModel vo(o.vo, body_T_cam, streamFor(seed, Stream::kVoNoise, session));
  WheelModel wheel(o.wheel, std::move(slips), streamFor(seed, Stream::kWheelNoise, session));
  Random attitude_rng = streamFor(seed, Stream::kAttitudeNoise, session);
  GyroHeadingModel gyro_heading(o.attitude, streamFor(seed, Stream::kGyroHeading, session));
  Random imu_rng = streamFor(seed, Stream::kImuNoise, session);
  Random floor_rng = streamFor(seed, Stream::kFloorNoise, session);
  const Vec3 imu_bias(o.imu.accel_bias_sigma_mps2 * imu_rng.normal(),
                      o.imu.accel_bias_sigma_mps2 * imu_rng.normal(),
                      o.imu.accel_bias_sigma_mps2 * imu_rng.normal());
  const Vec3 gyro_bias = gyroBias(o.imu, seed, session);
  const std::vector<floor_t> floors = floorEvents(building, plan, o.floor, floor_rng);

  TickClock gt_clock(start, o.ground_truth_rate_hz);
  ImuSchedule imu_clock(plan, o.imu, start, end);
  TickClock wheel_clock(start, o.wheel.rate_hz, 1);
  TickClock attitude_clock(start, o.attitude.rate_hz);
  TickClock vo_clock(start, o.vo.rate_hz);
  size_t floor_next = 0;
  int64_t wheel_prev_utime = start;
  BodyState wheel_prev = traj.at(start);

  // Dead reckoning with the VO deltas, for the drift figure of the summary.
  bool in_chain = false;
  SE3d chain_estimate;
  SE3d chain_truth;
  double chain_start_m = 0.0;
  double chain_end_m = 0.0;
  auto closeChain = [&]() {
    if (!in_chain) return;
    summary.vo_chains.push_back(
        VoChain{chain_end_m - chain_start_m,
                (chain_estimate.translation() - chain_truth.translation()).norm()});
    in_chain = false;
  };

  enum { kGt, kImu, kWheel, kAttitude, kFloor, kVo, kStreams };
  while (true) {
    const int64_t next[kStreams] = {gt_clock.next(),
                                    imu_clock.next(),
                                    wheel_clock.next(),
                                    attitude_clock.next(),
                                    floor_next < floors.size() ? floors[floor_next].utime : kNever,
                                    vo_clock.next()};
    int which = -1;
    for (int s = 0; s < kStreams; ++s) {
      if (next[s] <= end && (which < 0 || next[s] < next[which])) which = s;
    }
    if (which < 0) break;
    const int64_t t = next[which];
    switch (which) {
      case kGt: {
        const BodyState s = traj.at(t);
        writeMessage(sink, channels::kGroundTruth,
                     toPoseMessage(t, s.world_T_body, s.floor, session));
        if (observers.on_ground_truth) observers.on_ground_truth(t, s);
        gt_clock.advance();
        break;
      }
      case kImu:
        writeMessage(sink, channels::kImu,
                     measureImu(t, traj, o.imu, imu_bias, gyro_bias, imu_rng));
        imu_clock.advance();
        break;
      case kWheel: {
        const BodyState s = traj.at(t);
        writeMessage(sink, channels::kWheelOdom,
                     wheel.increment(wheel_prev_utime, wheel_prev, t, s));
        wheel_prev_utime = t;
        wheel_prev = s;
        wheel_clock.advance();
        break;
      }
      case kAttitude: {
        const BodyState s = traj.at(t);
        attitude_t m = measureAttitude(t, s, o.attitude, attitude_rng);
        if (o.attitude.heading) gyro_heading.fill(t, s, &m);
        writeMessage(sink, channels::kAttitude, m);
        attitude_clock.advance();
        break;
      }
      case kFloor:
        writeMessage(sink, channels::kFloor, floors[floor_next]);
        ++floor_next;
        break;
      case kVo: {
        const BodyState s = traj.at(t);
        const int8_t condition = visualCondition(building, s, body_T_cam, o.vo, passers, t);
        const vo_delta_t m = vo.frame(t, s, condition);
        if (calib_repeat.due(t))
          writeMessage(sink, channels::kStereoCalib, messages::toMsg(calibration, t));
        writeMessage(sink, channels::kVoDelta, m);
        ++summary.vo_frames;
        ++summary.vo_status[static_cast<size_t>(m.status)];
        const SE3d world_T_cam = s.world_T_body * body_T_cam;
        if (m.status == vo_delta_t::STATUS_NO_DATA) {
          closeChain();
          in_chain = true;
          chain_estimate = chain_truth = world_T_cam;
          chain_start_m = chain_end_m = s.odometer_m;
        } else if (m.status == vo_delta_t::STATUS_OK && m.keyframe_changed) {
          chain_estimate = chain_estimate * deltaOf(m);
          chain_truth = world_T_cam;
          chain_end_m = s.odometer_m;
        } else if (m.status != vo_delta_t::STATUS_OK) {
          closeChain();
        }
        if (m.keyframe_changed) {
          ++summary.vo_keyframes;
          // The oracle learns the keyframe before anyone can hear of it and ask.
          if (observers.on_keyframe) {
            observers.on_keyframe(KeyframeTruth{t, world_T_cam, s.floor, session});
          }
          writeMessage(sink, channels::kKeyframe, keyframeIdentity(t, o.camera));
        }
        vo_clock.advance();
        break;
      }
      default:
        break;
    }
  }
  closeChain();
  return summary;
}

}  // namespace evermap::sim
