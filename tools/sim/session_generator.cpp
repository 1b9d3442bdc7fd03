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

// Dead reckoning with the VO deltas, for the drift figure of the summary: a chain starts at
// each fresh VO start (NO_DATA) and ends at a failure.
class VoChains {
 public:
  void frame(const vo_delta_t& m, const SE3d& world_T_cam, double odometer_m,
             std::vector<VoChain>* chains) {
    if (m.status == vo_delta_t::STATUS_NO_DATA) {
      close(chains);
      in_chain_ = true;
      estimate_ = truth_ = world_T_cam;
      start_m_ = end_m_ = odometer_m;
    } else if (m.status == vo_delta_t::STATUS_OK && m.keyframe_changed) {
      estimate_ = estimate_ * deltaOf(m);
      truth_ = world_T_cam;
      end_m_ = odometer_m;
    } else if (m.status != vo_delta_t::STATUS_OK) {
      close(chains);
    }
  }
  void close(std::vector<VoChain>* chains) {
    if (!in_chain_) return;
    chains->push_back(
        VoChain{end_m_ - start_m_, (estimate_.translation() - truth_.translation()).norm()});
    in_chain_ = false;
  }

 private:
  bool in_chain_ = false;
  SE3d estimate_, truth_;
  double start_m_ = 0.0, end_m_ = 0.0;
};

// The session's wheel slips, and how many.
Intervals slipsOf(const WheelOptions& o, uint64_t seed, int session, int64_t start, int64_t end,
                  int64_t* count) {
  Random rng = streamFor(seed, Stream::kSlips, session);
  Intervals slips(start, end, o.slip_rate_per_hour, o.slip_min_s, o.slip_max_s, rng);
  *count = static_cast<int64_t>(slips.size());
  return slips;
}

Intervals passersOf(const VoOptions& o, uint64_t seed, int session, int64_t start, int64_t end) {
  Random rng = streamFor(seed, Stream::kPassersBy, session);
  return Intervals(start, end, o.passerby_rate_per_hour, o.passerby_min_s, o.passerby_max_s, rng);
}

// One session's sensor streams, each from its own clock and noise stream, written in time
// order.
class SessionWriter {
 public:
  SessionWriter(const Building& building, const SessionPlan& plan, const SensorOptions& o,
                uint64_t seed, MessageSink& sink, const SessionObservers& observers)
      : building_(building),
        o_(o),
        sink_(sink),
        observers_(observers),
        traj_(*plan.trajectory),
        start_(traj_.startUtime()),
        end_(traj_.endUtime()),
        session_(plan.index),
        body_T_cam_(o.camera.bodyTCam()),
        // The camera the VO deltas are of (DESIGN.md: calibration is state, repeated).
        calibration_(o.camera.stereoCalibration(static_cast<int>(std::lround(2.0 * o.camera.cx)),
                                                static_cast<int>(std::lround(2.0 * o.camera.cy)))),
        passers_(passersOf(o.vo, seed, session_, start_, end_)),
        vo_(o.vo, body_T_cam_, streamFor(seed, Stream::kVoNoise, session_)),
        wheel_(o.wheel, slipsOf(o.wheel, seed, session_, start_, end_, &slip_events_),
               streamFor(seed, Stream::kWheelNoise, session_)),
        attitude_rng_(streamFor(seed, Stream::kAttitudeNoise, session_)),
        gyro_heading_(o.attitude, streamFor(seed, Stream::kGyroHeading, session_)),
        imu_rng_(streamFor(seed, Stream::kImuNoise, session_)),
        imu_bias_(accelBias(o.imu, imu_rng_)),
        gyro_bias_(gyroBias(o.imu, seed, session_)),
        gt_clock_(start_, o.ground_truth_rate_hz),
        imu_clock_(plan, o.imu, start_, end_),
        wheel_clock_(start_, o.wheel.rate_hz, 1),
        attitude_clock_(start_, o.attitude.rate_hz),
        vo_clock_(start_, o.vo.rate_hz),
        wheel_prev_utime_(start_),
        wheel_prev_(traj_.at(start_)) {
    Random floor_rng = streamFor(seed, Stream::kFloorNoise, session_);
    floors_ = floorEvents(building, plan, o.floor, floor_rng);
    summary_.session = session_;
    summary_.start_utime = start_;
    summary_.end_utime = end_;
    summary_.distance_m = plan.distance_m;
    summary_.rides = static_cast<int>(plan.rides.size());
    summary_.floors_visited = plan.floors_visited;
    summary_.passerby_events = static_cast<int64_t>(passers_.size());
    summary_.slip_events = slip_events_;
  }

  SessionSummary run() {
    enum { kGt, kImu, kWheel, kAttitude, kFloor, kVo, kStreams };
    while (true) {
      const int64_t next[kStreams] = {
          gt_clock_.next(),
          imu_clock_.next(),
          wheel_clock_.next(),
          attitude_clock_.next(),
          floor_next_ < floors_.size() ? floors_[floor_next_].utime : kNever,
          vo_clock_.next()};
      int which = -1;
      for (int s = 0; s < kStreams; ++s) {
        if (next[s] <= end_ && (which < 0 || next[s] < next[which])) which = s;
      }
      if (which < 0) break;
      const int64_t t = next[which];
      if (which == kGt) groundTruth(t);
      if (which == kImu) {
        writeMessage(sink_, channels::kImu,
                     measureImu(t, traj_, o_.imu, imu_bias_, gyro_bias_, imu_rng_));
        imu_clock_.advance();
      }
      if (which == kWheel) wheelTick(t);
      if (which == kAttitude) attitudeTick(t);
      if (which == kFloor) writeMessage(sink_, channels::kFloor, floors_[floor_next_++]);
      if (which == kVo) voFrame(t);
    }
    chains_.close(&summary_.vo_chains);
    return summary_;
  }

 private:
  void groundTruth(int64_t t) {
    const BodyState s = traj_.at(t);
    writeMessage(sink_, channels::kGroundTruth,
                 toPoseMessage(t, s.world_T_body, s.floor, session_));
    if (observers_.on_ground_truth) observers_.on_ground_truth(t, s);
    gt_clock_.advance();
  }

  void wheelTick(int64_t t) {
    const BodyState s = traj_.at(t);
    writeMessage(sink_, channels::kWheelOdom,
                 wheel_.increment(wheel_prev_utime_, wheel_prev_, t, s));
    wheel_prev_utime_ = t;
    wheel_prev_ = s;
    wheel_clock_.advance();
  }

  void attitudeTick(int64_t t) {
    const BodyState s = traj_.at(t);
    attitude_t m = measureAttitude(t, s, o_.attitude, attitude_rng_);
    if (o_.attitude.heading) gyro_heading_.fill(t, s, &m);
    writeMessage(sink_, channels::kAttitude, m);
    attitude_clock_.advance();
  }

  void voFrame(int64_t t) {
    const BodyState s = traj_.at(t);
    const int8_t condition = visualCondition(building_, s, body_T_cam_, o_.vo, passers_, t);
    const vo_delta_t m = vo_.frame(t, s, condition);
    if (calib_repeat_.due(t))
      writeMessage(sink_, channels::kStereoCalib, messages::toMsg(calibration_, t));
    writeMessage(sink_, channels::kVoDelta, m);
    ++summary_.vo_frames;
    ++summary_.vo_status[static_cast<size_t>(m.status)];
    const SE3d world_T_cam = s.world_T_body * body_T_cam_;
    chains_.frame(m, world_T_cam, s.odometer_m, &summary_.vo_chains);
    if (m.keyframe_changed) {
      ++summary_.vo_keyframes;
      // The oracle learns the keyframe before anyone can hear of it and ask.
      if (observers_.on_keyframe) {
        observers_.on_keyframe(KeyframeTruth{t, world_T_cam, s.floor, session_});
      }
      writeMessage(sink_, channels::kKeyframe, keyframeIdentity(t, o_.camera));
    }
    vo_clock_.advance();
  }

  const Building& building_;
  const SensorOptions& o_;
  MessageSink& sink_;
  const SessionObservers& observers_;
  const Trajectory& traj_;
  const int64_t start_, end_;
  const int session_;
  const SE3d body_T_cam_;
  const core::StereoCalibration calibration_;
  channels::CalibrationRepeat calib_repeat_;
  const Intervals passers_;
  int64_t slip_events_ = 0;
  VoModel vo_;
  WheelModel wheel_;
  Random attitude_rng_;
  GyroHeadingModel gyro_heading_;
  Random imu_rng_;
  const Vec3 imu_bias_;
  const Vec3 gyro_bias_;
  std::vector<floor_t> floors_;
  TickClock gt_clock_;
  ImuSchedule imu_clock_;
  TickClock wheel_clock_, attitude_clock_, vo_clock_;
  size_t floor_next_ = 0;
  int64_t wheel_prev_utime_;
  BodyState wheel_prev_;
  VoChains chains_;
  SessionSummary summary_;
};

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
  return SessionWriter(building, plan, o, seed, sink, observers).run();
}

}  // namespace evermap::sim
