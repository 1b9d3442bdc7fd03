#pragma once
// A scripted drive for the mapper tests: along a corridor and back with exact VO, each
// request answered by a registration oracle from the truth.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <numbers>

#include "core/messages/odometry_frame.h"
#include "mapper-proc/map_store.h"
#include "mapper-proc/mapper.h"
#include "tests/mapper_messages.h"

namespace evermap::mapper::testing {

// What a restarted mapper's first VO_DELTA says of the odometry frame (ScriptedDrive::restart).
enum class GapOdometry {
  kNone,       // no odometry pose (a sender without one)
  kSameEpoch,  // VO went on through the gap: the same epoch, the gap's motion in it
  kNewEpoch,   // vo-proc restarted too: its first frame starts a new epoch
};

// A scripted drive along a corridor and back, twice, with exact VO and a registration oracle
// that answers from the truth within 1.5 m.
class ScriptedDrive {
 public:
  explicit ScriptedDrive(MapperOptions o, double registration_variance = 1e-4)
      : mapper_(std::make_unique<Mapper>(o)), registration_variance_(registration_variance) {
    floor_t f{};
    f.floor_index = 0;
    EXPECT_TRUE(mapper_->onFloor(f));
  }

  // Drives to `goal` in steps of 0.1 m / 0.1 s, keeping the heading of travel.
  void driveTo(double x, double yaw) {
    for (;;) {
      const double dx = x - pose_.translation().x();
      const double dyaw = core::wrapAngle(yaw - yawOf(pose_));
      if (std::abs(dx) < 1e-9 && std::abs(dyaw) < 1e-9) return;
      SE3d next = pose_;
      if (std::abs(dyaw) > 1e-9) {
        next = pose_ * planar(0, 0, std::clamp(dyaw, -0.3, 0.3));
      } else {
        next = SE3d(pose_.so3(), pose_.translation() + Vec3(std::clamp(dx, -0.1, 0.1), 0, 0));
      }
      frame(next);
    }
  }
  // Registrations fail from now on (a dark corridor), until blind(false).
  void blind(bool on) { blind_ = on; }
  // VO's standard deviation per frame (0.1 m), metres and radians (1e-3 by default).
  void voSigma(double sigma) { vo_sigma_ = sigma; }
  // From now on every frame's planar motion also reaches the mapper as WHEEL_ODOM (exact,
  // σ 1 mm / 1 mrad per increment, stamped with the wheels' odometry pose), after the frame's
  // VO_DELTA; at a restart, before the first VO_DELTA unless `late`.
  void wheels(bool on, bool late = false) {
    wheels_ = on;
    wheels_late_ = late;
  }
  // The wheel driver restarts: its next increment starts a new odometry epoch.
  void restartWheelDriver() { wheel_odom_ = messages::WheelOdometryFrame{}; }
  // Only the next `n` global searches find a place (by appearance); later ones find none,
  // node-mode requests still register (-1: every search finds one).
  void globalSearchesFind(int n) { global_finds_ = n; }
  // Steps `dy` metres sideways (along y), heading kept, VO seeing it.
  void sidestep(double dy) { frame(SE3d(pose_.so3(), pose_.translation() + Vec3(0, dy, 0))); }
  // The robot slides `dx` metres along x without VO seeing it (a wheel slip VO missed, a
  // kidnapping): VO reports no motion, with its usual confidence.
  void slip(double dx) {
    slipBy(pose_.inverse() * SE3d(pose_.so3(), pose_.translation() + Vec3(dx, 0, 0)));
  }
  // The robot moves by `motion` (body frame) while VO reports standing still: odometry error.
  void slipBy(const SE3d& motion) {
    utime_ += 100000;
    EXPECT_TRUE(send(voMsg(utime_, utime_ - 100000, SE3d(), vo_sigma_, true)));
    pose_ = pose_ * motion;
    truth_[utime_] = pose_;
    answer();
  }
  const SE3d& truePose() const { return pose_; }
  // A repeated texture: from now on registrations see the robot `dx` metres further along x
  // than it is (0: the truth again).
  void aliasBy(double dx) { alias_dx_ = dx; }
  // The true body pose at a node's keyframe.
  const SE3d& nodeTruth(int64_t id) const { return node_truth_.at(id); }
  Mapper& mapper() { return *mapper_; }
  // mapper-proc killed and restarted from its store: a new mapper with options `o` restores
  // `map`, and nothing reaches it for `gap_s` seconds, in which the robot moves `moved_dx`
  // metres along its heading. Then VO goes on from a reference the new mapper never saw; its
  // odometry pose is as `odometry` says (VO ran through the gap, its frames lost to the mapper).
  Status restart(const MapSnapshot& map, const MapperOptions& o, double gap_s,
                 double moved_dx = 0.0, GapOdometry odometry = GapOdometry::kNone) {
    mapper_ = std::make_unique<Mapper>(o);
    if (Status s = mapper_->restore(map); !s) return s;
    const auto gap = static_cast<int64_t>(gap_s * 1e6);
    const int64_t frames = std::max<int64_t>(1, gap / 100000);
    for (int64_t k = 1; k <= frames; ++k) {
      // VO's frames in the gap, seen by the odometry frames only.
      const int64_t previous = utime_;
      utime_ += gap / frames;
      const SE3d step = planar(moved_dx / static_cast<double>(frames), 0, 0);
      vo_delta_t m = voMsg(utime_, previous, step, 1e-3, true);
      odom_.stamp(m);
      if (wheels_) (void)wheelMsg(previous, utime_, step);
      pose_ = pose_ * step;
    }
    utime_ += 100000;
    // The robot stood still over this frame: VO's motion from its (unknown) reference.
    vo_delta_t first = odometry == GapOdometry::kNewEpoch
                           ? voRestart(utime_)
                           : voMsg(utime_, utime_ - 100000, SE3d(), 1e-3, true);
    if (odometry != GapOdometry::kNone) odom_.stamp(first);
    const wheel_odom_t wheel = wheelMsg(utime_ - 100000, utime_, SE3d());
    if (wheels_ && !wheels_late_) {
      EXPECT_TRUE(mapper_->onWheel(wheel));
    }
    const Status s = mapper_->onVo(first);
    if (wheels_ && wheels_late_) {
      EXPECT_TRUE(mapper_->onWheel(wheel));
    }
    truth_[utime_] = pose_;
    answer();
    return s;
  }
  int64_t utime() const { return utime_; }
  // An elevator ride that ends where it started, on floor `index`, whose height estimate says
  // `height_m` with standard deviation `sigma_m`.
  void rideEnd(int index, double height_m, double sigma_m) {
    floor_t f{};
    f.utime = utime_;
    f.floor_index = index;
    f.height_m = height_m;
    f.height_sigma_m = sigma_m;
    f.event = floor_t::EVENT_RIDE_END;
    EXPECT_TRUE(mapper_->onFloor(f));
  }
  // The robot is off for `seconds` and starts again where it stopped, VO from a new
  // keyframe; the new session's FLOOR message arrives only when `announce`.
  void newSession(double seconds, bool announce) {
    utime_ += static_cast<int64_t>(seconds * 1e6);
    if (announce) {
      floor_t f{};
      f.utime = utime_;
      f.floor_index = 0;
      EXPECT_TRUE(mapper_->onFloor(f));
    }
    utime_ += 100000;
    EXPECT_TRUE(send(voRestart(utime_)));
    truth_[utime_] = pose_;
    answer();
  }

 private:
  static double yawOf(const SE3d& p) { return core::toPlanar(p).theta(); }
  // A VO_DELTA stamped with its odometry pose, as vo-proc sends it.
  Status send(vo_delta_t m) {
    odom_.stamp(m);
    return mapper_->onVo(m);
  }
  // A WHEEL_ODOM increment of the planar part of `motion`, stamped with its odometry pose.
  wheel_odom_t wheelMsg(int64_t prev_utime, int64_t utime, const SE3d& motion) {
    const core::SE2d d = core::toPlanar(motion);
    wheel_odom_t w{};
    w.prev_utime = prev_utime;
    w.utime = utime;
    w.delta_x_m = d.x();
    w.delta_y_m = d.y();
    w.delta_theta_rad = d.theta();
    w.covariance[0] = w.covariance[4] = w.covariance[8] = 1e-6;
    wheel_odom_.stamp(w);
    return w;
  }
  void frame(const SE3d& next) {
    utime_ += 100000;
    if (truth_.empty()) {
      EXPECT_TRUE(send(voRestart(utime_)));
    } else {
      EXPECT_TRUE(send(voMsg(utime_, utime_ - 100000, pose_.inverse() * next, vo_sigma_, true)));
      if (wheels_) {
        EXPECT_TRUE(mapper_->onWheel(wheelMsg(utime_ - 100000, utime_, pose_.inverse() * next)));
      }
    }
    pose_ = next;
    truth_[utime_] = next;
    answer();
  }
  void answer() {
    for (int guard = 0; guard < 4; ++guard) {
      for (const auto& n : mapper_->takeNodesAdded())
        node_truth_[n.node_id] = truth_.at(n.keyframe_utime);
      const auto requests = mapper_->takeRequests();
      if (requests.empty()) return;
      for (const auto& r : requests) {
        register_result_t res{};
        res.request_id = r.request_id;
        res.keyframe_utime = r.keyframe_utime;
        res.status = register_result_t::STATUS_NO_CANDIDATE;
        const SE3d q = SE3d(core::SO3d(), Vec3(alias_dx_, 0, 0)) * truth_.at(r.keyframe_utime);
        int64_t best = -1;
        double best_d = 1.5;
        const bool global = r.mode == register_request_t::MODE_GLOBAL;
        if (global && global_finds_ == 0) {
          EXPECT_TRUE(mapper_->onRegisterResult(res));
          continue;
        }
        if (global && global_finds_ > 0) --global_finds_;
        for (const auto& [id, p] : node_truth_) {
          if (blind_) break;
          if (r.mode == register_request_t::MODE_NODE && id != r.target_node_id) continue;
          const double d = (p.translation() - q.translation()).norm() +
                           std::abs(core::wrapAngle(yawOf(p) - yawOf(q)));
          if (d < best_d) best_d = d, best = id;
        }
        if (best >= 0) {
          const SE3d rel = node_truth_.at(best).inverse() * q;
          res = register_result_t{};
          res.request_id = r.request_id;
          res.keyframe_utime = r.keyframe_utime;
          res.status = register_result_t::STATUS_OK;
          res.node_id = best;
          messages::putPose(rel, res.translation, res.orientation);
          for (int i = 0; i < 6; ++i) res.covariance[7 * i] = registration_variance_;
        }
        EXPECT_TRUE(mapper_->onRegisterResult(res));
      }
    }
  }

  std::unique_ptr<Mapper> mapper_;
  messages::OdometryFrame odom_;             // vo-proc's, which no mapper restart resets
  messages::WheelOdometryFrame wheel_odom_;  // the wheel driver's
  bool wheels_ = false;
  bool wheels_late_ = false;
  double registration_variance_;
  double alias_dx_ = 0.0;
  double vo_sigma_ = 1e-3;
  bool blind_ = false;
  int global_finds_ = -1;
  SE3d pose_;
  int64_t utime_ = 0;
  std::map<int64_t, SE3d> truth_;
  std::map<int64_t, SE3d> node_truth_;
};

inline MapperOptions scriptedOptions() {
  MapperOptions o;
  o.tracker.body_T_cam = SE3d();
  o.step_interval_s = 0.3;
  return o;
}

// The partner bound (MapperOptions::closure_partners) at `partners`, and no saturated pair
// informative enough to open (no closure tells the map 1000 nats).
inline MapperOptions withPartners(int partners) {
  MapperOptions o = scriptedOptions();
  o.closure_partners = partners;
  o.saturated_closure_information = 1e3;
  return o;
}

inline void lap(ScriptedDrive& drive) {
  drive.driveTo(8.0, 0.0);
  drive.driveTo(8.0, std::numbers::pi);
  drive.driveTo(0.0, std::numbers::pi);
  drive.driveTo(0.0, 0.0);
}

}  // namespace evermap::mapper::testing
