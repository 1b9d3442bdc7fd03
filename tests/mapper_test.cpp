// mapper-proc: the tracker (eq. 6-7), the constraint set, Algorithm 1 on a scripted drive, and
// the reduced against the full pose graph on a simulated run.

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>

#include "core/sim/registration_oracle.h"
#include "tests/scratch_dir.h"
#include "mapper-proc/constraint_set.h"
#include "mapper-proc/map_store.h"
#include "mapper-proc/mapper.h"
#include "mapper-proc/offline_run.h"
#include "mapper-proc/tracker.h"
#include "tests/sim_test_support.h"

namespace evermap::mapper {
namespace {

using core::Mat6;
using core::SE3d;
using core::UncertainPose;
using core::Vec3;
using core::Vec6;

SE3d planar(double x, double y, double yaw) {
  return SE3d(core::SO3d::exp(Vec3(0, 0, yaw)), Vec3(x, y, 0));
}

vo_delta_t voMsg(int64_t utime, int64_t ref, const SE3d& ref_T_cur, double sigma, bool keyframe) {
  vo_delta_t m{};
  m.utime = utime;
  m.ref_utime = ref;
  m.status = vo_delta_t::STATUS_OK;
  m.keyframe_changed = keyframe ? 1 : 0;
  for (int i = 0; i < 3; ++i) m.translation[i] = ref_T_cur.translation()[i];
  const auto& q = ref_T_cur.quaternion();
  m.orientation[0] = q.w();
  m.orientation[1] = q.x();
  m.orientation[2] = q.y();
  m.orientation[3] = q.z();
  for (int i = 0; i < 6; ++i) m.covariance[7 * i] = sigma * sigma;
  return m;
}

vo_delta_t voRestart(int64_t utime) {
  vo_delta_t m = voMsg(utime, utime, SE3d(), 0.0, true);
  m.status = vo_delta_t::STATUS_NO_DATA;
  return m;
}

TEST(Tracker, CompoundsTheKeyframeChainByEquationsSixAndSeven) {
  Tracker t(TrackerOptions{});
  ASSERT_TRUE(t.addVo(voRestart(0)));
  const SE3d step = planar(0.1, 0.0, 0.05);
  UncertainPose expected;
  UncertainPose inc{step, Mat6::Identity() * 1e-4};
  for (int k = 1; k <= 10; ++k) {
    ASSERT_TRUE(t.addVo(voMsg(k * 100000, (k - 1) * 100000, step, 1e-2, true)));
    expected = core::compound(expected, inc);
  }
  const UncertainPose d = t.delta();
  EXPECT_LT((d.mean.inverse() * expected.mean).log().norm(), 1e-12);
  EXPECT_LT((d.covariance - expected.covariance).norm(), 1e-15);
  // Uncertainty grows along the chain.
  EXPECT_GT(d.covariance.determinant(), std::pow(1e-4, 6));
  // The motion since keyframe 4 is the last six increments.
  const auto since = t.sinceKeyframe(400000);
  ASSERT_TRUE(since.has_value());
  SE3d six;
  for (int k = 0; k < 6; ++k) six = six * step;
  EXPECT_LT((since->mean.inverse() * six).log().norm(), 1e-12);
  EXPECT_FALSE(t.sinceKeyframe(450000).has_value());
}

TEST(Tracker, FallsBackToWheelOdometryWhenVoFails) {
  Tracker t(TrackerOptions{});
  ASSERT_TRUE(t.addVo(voRestart(0)));
  ASSERT_TRUE(t.addVo(voMsg(100000, 0, planar(0.1, 0, 0), 1e-3, true)));
  vo_delta_t fail = voMsg(200000, 100000, SE3d(), 0, false);
  fail.status = vo_delta_t::STATUS_INSUFFICIENT_FEATURES;
  ASSERT_TRUE(t.addVo(fail));
  EXPECT_FALSE(t.voTracking());
  for (int k = 3; k <= 7; ++k) {
    wheel_odom_t w{};
    w.prev_utime = (k - 1) * 100000;
    w.utime = k * 100000;
    w.delta_x_m = 0.2;
    w.covariance[0] = w.covariance[4] = w.covariance[8] = 1e-4;
    ASSERT_TRUE(t.addWheel(w));
  }
  EXPECT_EQ(t.counts().wheel_applied, 5);
  EXPECT_NEAR(t.delta().mean.translation().x(), 0.1 + 5 * 0.2, 1e-12);
  // VO restarts a wheel period after the last wheel message: the reference is placed where
  // the wheels' last rate (2 m/s) has the body then. After it, wheel odometry is no longer used.
  ASSERT_TRUE(t.addVo(voRestart(800000)));
  EXPECT_NEAR(t.delta().mean.translation().x(), 1.1 + 0.2, 1e-12);
  wheel_odom_t w{};
  w.prev_utime = 800000;
  w.utime = 900000;
  w.delta_x_m = 5.0;
  ASSERT_TRUE(t.addWheel(w));
  EXPECT_NEAR(t.delta().mean.translation().x(), 1.3, 1e-12);
}

TEST(Tracker, DropsOutOfOrderAndMalformedMessages) {
  Tracker t(TrackerOptions{});
  ASSERT_TRUE(t.addVo(voRestart(100)));
  EXPECT_FALSE(t.addVo(voRestart(50)));
  vo_delta_t bad = voMsg(200, 100, SE3d(), 1e-3, true);
  bad.translation[0] = std::nan("");
  EXPECT_FALSE(t.addVo(bad));
  vo_delta_t future_ref = voMsg(300, 400, planar(1, 0, 0), 1e-3, false);
  EXPECT_FALSE(t.addVo(future_ref));
  EXPECT_EQ(t.counts().dropped, 3);
  EXPECT_LT(t.delta().mean.log().norm(), 1e-15);
}

wheel_odom_t wheelMsg(int64_t prev, int64_t utime, double dx, double variance = 1e-4) {
  wheel_odom_t w{};
  w.prev_utime = prev;
  w.utime = utime;
  w.delta_x_m = dx;
  w.covariance[0] = w.covariance[4] = w.covariance[8] = variance;
  return w;
}

TEST(Tracker, AChainBreakStartsANewReferenceAndTheFramesAfterItAreUsed) {
  // vo-proc's chain break: a failed frame becomes the reference (keyframe_changed, its own
  // utime). Wheel odometry covers the failed frames; VO continues from the new reference.
  Tracker t(TrackerOptions{});
  ASSERT_TRUE(t.addVo(voRestart(0)));
  ASSERT_TRUE(t.addVo(voMsg(100000, 0, planar(0.1, 0, 0), 1e-3, false)));
  ASSERT_TRUE(t.addWheel(wheelMsg(100000, 200000, 0.1)));
  vo_delta_t fail = voMsg(200000, 0, SE3d(), 0, false);
  fail.status = vo_delta_t::STATUS_INSUFFICIENT_INLIERS;
  ASSERT_TRUE(t.addVo(fail));
  EXPECT_FALSE(t.voTracking());
  ASSERT_TRUE(t.addWheel(wheelMsg(200000, 300000, 0.1)));
  vo_delta_t brk = voMsg(300000, 300000, SE3d(), 0, true);
  brk.status = vo_delta_t::STATUS_INSUFFICIENT_INLIERS;
  ASSERT_TRUE(t.addVo(brk));
  EXPECT_TRUE(t.voTracking());
  EXPECT_EQ(t.referenceUtime(), 300000);
  ASSERT_TRUE(t.addVo(voMsg(400000, 300000, planar(0.1, 0, 0), 1e-3, true)));
  ASSERT_TRUE(t.addVo(voMsg(500000, 400000, planar(0.1, 0, 0), 1e-3, false)));
  // 0.1 VO + 0.2 wheel (the increment before the failure message included) + 0.2 VO.
  EXPECT_NEAR(t.delta().mean.translation().x(), 0.5, 1e-12);
  EXPECT_EQ(t.counts().dropped, 0);
  EXPECT_EQ(t.counts().restarts, 2);
  // An older vo-proc stamped the break with the old reference: a restart all the same.
  vo_delta_t old_style = voMsg(600000, 400000, SE3d(), 0, true);
  old_style.status = vo_delta_t::STATUS_INSUFFICIENT_INLIERS;
  ASSERT_TRUE(t.addVo(old_style));
  EXPECT_EQ(t.referenceUtime(), 600000);
  ASSERT_TRUE(t.addVo(voMsg(700000, 600000, planar(0.1, 0, 0), 1e-3, false)));
  EXPECT_EQ(t.counts().dropped, 0);
}

TEST(Tracker, VoBackOnItsKeptReferenceReplacesTheWheelOdometryOfTheGap) {
  // A passer-by: VO fails twice, keeps its reference and registers against it again. Its
  // motion from the reference replaces the (less precise) wheel odometry of the gap.
  Tracker t(TrackerOptions{});
  ASSERT_TRUE(t.addVo(voRestart(0)));
  ASSERT_TRUE(t.addVo(voMsg(100000, 0, planar(0.1, 0, 0), 1e-3, true)));
  ASSERT_TRUE(t.addVo(voMsg(200000, 100000, planar(0.1, 0, 0), 1e-3, false)));
  for (int k = 3; k <= 4; ++k) {
    vo_delta_t fail = voMsg(k * 100000, 100000, SE3d(), 0, false);
    fail.status = vo_delta_t::STATUS_INSUFFICIENT_INLIERS;
    ASSERT_TRUE(t.addVo(fail));
    ASSERT_TRUE(t.addWheel(wheelMsg((k - 1) * 100000, k * 100000, 0.2, 1e-2)));  // σ 0.1 m
  }
  EXPECT_FALSE(t.voTracking());
  EXPECT_NEAR(t.delta().mean.translation().x(), 0.2 + 0.4, 1e-12);
  const UncertainPose before = t.delta();
  ASSERT_TRUE(t.addVo(voMsg(500000, 100000, planar(0.4, 0, 0), 1e-3, false)));
  EXPECT_TRUE(t.voTracking());
  EXPECT_EQ(t.counts().relinked, 1);
  EXPECT_NEAR(t.delta().mean.translation().x(), 0.1 + 0.4, 1e-12);
  // The covariance does not shrink below what it was: the wheel's share stays (conservative).
  EXPECT_GE(t.delta().covariance(0, 0), before.covariance(0, 0));
  // The chain goes on: a keyframe change and a frame after it.
  ASSERT_TRUE(t.addVo(voMsg(600000, 100000, planar(0.5, 0, 0), 1e-3, true)));
  ASSERT_TRUE(t.addVo(voMsg(700000, 600000, planar(0.1, 0, 0), 1e-3, false)));
  EXPECT_NEAR(t.delta().mean.translation().x(), 0.7, 1e-12);
  const auto since = t.sinceKeyframe(100000);
  ASSERT_TRUE(since.has_value());
  EXPECT_NEAR(since->mean.translation().x(), 0.6, 1e-12);
  EXPECT_EQ(t.counts().dropped, 0);
}

// VO on keyframe 0.1 s, blind from 0.2 s (a dark room) while precise wheels (σ 1 mm per
// 0.1 s) drive 1 m/s until 1.1 s.
void loseVoOverAMetreOfWheels(Tracker& t) {
  ASSERT_TRUE(t.addVo(voRestart(0)));
  ASSERT_TRUE(t.addVo(voMsg(100000, 0, planar(0.1, 0, 0), 1e-3, true)));
  vo_delta_t fail = voMsg(200000, 100000, SE3d(), 0, false);
  fail.status = vo_delta_t::STATUS_INSUFFICIENT_FEATURES;
  ASSERT_TRUE(t.addVo(fail));
  for (int k = 2; k <= 11; ++k) ASSERT_TRUE(t.addWheel(wheelMsg((k - 1) * 100000, k * 100000, 0.1, 1e-6)));
}

TEST(Tracker, VoBackOnItsKeptReferenceIsNotBelievedWhenTheWheelsContradictIt) {
  // After a long gap VO registers against its old reference with a motion 0.6 m short of
  // what precise wheels measured (a repeated floor texture): the wheels' estimate stays.
  Tracker t(TrackerOptions{});
  ASSERT_NO_FATAL_FAILURE(loseVoOverAMetreOfWheels(t));
  ASSERT_TRUE(t.addVo(voMsg(1200000, 100000, planar(0.4, 0, 0), 1e-4, false)));
  EXPECT_EQ(t.counts().relinks_refused, 1);
  EXPECT_EQ(t.counts().relinked, 0);
  // The wheels reached 1.1 s; the frame at 1.2 s goes where their last rate (1 m/s) has the
  // body then.
  EXPECT_NEAR(t.delta().mean.translation().x(), 0.1 + 1.0 + 0.1, 1e-9);
  // And the frames after it move on from there.
  ASSERT_TRUE(t.addVo(voMsg(1300000, 100000, planar(0.5, 0, 0), 1e-4, false)));
  EXPECT_NEAR(t.delta().mean.translation().x(), 1.3, 1e-9);
}

TEST(Tracker, AMotionVoPredictedOverTheGapDoesNotReplaceTheWheels) {
  // VO bridges a break with its motion prior (contracts.md): back on its old reference with a
  // motion it predicted, 0.1 m and 3 degrees off what precise wheels measured, and a
  // covariance of decimetres. That agrees with the wheels within its uncertainty, but it is
  // the weaker of the two: the wheels keep the gap, and the chain goes on from there.
  Tracker t(TrackerOptions{});
  ASSERT_NO_FATAL_FAILURE(loseVoOverAMetreOfWheels(t));
  ASSERT_TRUE(t.addVo(voMsg(1200000, 100000, planar(1.0, 0, 0.05), 0.3, true)));
  EXPECT_EQ(t.counts().relinks_weaker, 1);
  EXPECT_EQ(t.counts().relinks_refused, 0);
  EXPECT_EQ(t.counts().relinked, 0);
  EXPECT_NEAR(t.delta().mean.translation().x(), 0.1 + 1.0 + 0.1, 1e-9);
  EXPECT_NEAR(core::toPlanar(t.delta().mean).theta(), 0.0, 1e-9);
  ASSERT_TRUE(t.addVo(voMsg(1300000, 1200000, planar(0.1, 0, 0), 1e-3, false)));
  EXPECT_NEAR(t.delta().mean.translation().x(), 1.3, 1e-9);
  EXPECT_EQ(t.counts().dropped, 0);
}

TEST(Tracker, AFrameOnAnUnknownReferenceIsReanchoredWhereWheelOdometryPutsTheBody) {
  // The keyframe change was lost (or vo-proc restarted without a first frame): the frames
  // name a reference the tracker never saw. They are used, not refused: the first one sits
  // where the estimate is, the next ones move on from it.
  Tracker t(TrackerOptions{});
  ASSERT_TRUE(t.addVo(voRestart(0)));
  ASSERT_TRUE(t.addVo(voMsg(100000, 0, planar(0.1, 0, 0), 1e-3, false)));
  ASSERT_TRUE(t.addVo(voMsg(300000, 250000, planar(0.05, 0, 0), 1e-3, false)));
  EXPECT_EQ(t.counts().reanchored, 1);
  EXPECT_NEAR(t.delta().mean.translation().x(), 0.1, 1e-12);
  ASSERT_TRUE(t.addVo(voMsg(400000, 250000, planar(0.25, 0, 0), 1e-3, true)));
  EXPECT_NEAR(t.delta().mean.translation().x(), 0.3, 1e-12);
  ASSERT_TRUE(t.addVo(voMsg(500000, 400000, planar(0.1, 0, 0), 1e-3, false)));
  EXPECT_NEAR(t.delta().mean.translation().x(), 0.4, 1e-12);
  EXPECT_EQ(t.counts().dropped, 0);
  // The motion since the first keyframe still compounds to Δ.
  const auto since = t.sinceKeyframe(0);
  ASSERT_TRUE(since.has_value());
  EXPECT_NEAR(since->mean.translation().x(), 0.4, 1e-12);
}

TEST(Tracker, SilentVoHandsOverToWheelOdometryFromItsLastFrame) {
  // vo-proc killed: no failure message, just silence. After vo_timeout_s of wheel messages
  // the wheel increments since the last VO frame are compounded; a restarted vo-proc's first
  // frame starts from there.
  TrackerOptions o;
  o.vo_timeout_s = 0.5;
  Tracker t(o);
  ASSERT_TRUE(t.addVo(voRestart(0)));
  ASSERT_TRUE(t.addVo(voMsg(100000, 0, planar(0.1, 0, 0), 1e-3, false)));
  for (int k = 2; k <= 10; ++k) ASSERT_TRUE(t.addWheel(wheelMsg((k - 1) * 100000, k * 100000, 0.1)));
  EXPECT_FALSE(t.voTracking());
  EXPECT_EQ(t.counts().vo_timeouts, 1);
  EXPECT_NEAR(t.delta().mean.translation().x(), 0.1 + 0.9, 1e-12);
  ASSERT_TRUE(t.addVo(voRestart(1000000)));
  ASSERT_TRUE(t.addVo(voMsg(1100000, 1000000, planar(0.1, 0, 0), 1e-3, false)));
  EXPECT_NEAR(t.delta().mean.translation().x(), 1.1, 1e-12);
}

TEST(ConstraintSet, AgreeingConstraintsMergeAndInconsistentOnesAreRejected) {
  ConstraintSet set(16.81);
  Constraint c;
  c.from = 3;
  c.to = 5;
  c.from_T_to = UncertainPose{planar(1.0, 0, 0), Mat6::Identity() * 0.01};
  EXPECT_EQ(set.add(c), ConstraintSet::Outcome::kNewPair);
  // The same pair measured the other way round, slightly differently: merged.
  Constraint d = c;
  std::swap(d.from, d.to);
  d.from_T_to = core::invert(UncertainPose{planar(1.05, 0, 0), Mat6::Identity() * 0.01});
  EXPECT_EQ(set.add(d), ConstraintSet::Outcome::kMerged);
  const auto& pair = set.pairs().at({3, 5});
  EXPECT_NEAR(pair.i_T_j.mean.translation().x(), 1.025, 1e-3);
  EXPECT_NEAR(pair.i_T_j.covariance(0, 0), 0.005, 1e-4);
  // Three metres off: rejected, counted, kept.
  Constraint e = c;
  e.from_T_to.mean = planar(4.0, 0, 0);
  EXPECT_EQ(set.add(e), ConstraintSet::Outcome::kRejected);
  EXPECT_EQ(set.rejected(), 1);
  EXPECT_EQ(set.merged(), 1);
  EXPECT_EQ(set.all().size(), 3u);
  EXPECT_FALSE(set.all().back().accepted);
  EXPECT_EQ(set.pairs().at({3, 5}).members.size(), 3u);
}

// A scripted drive along a corridor and back, twice, with exact VO and a registration oracle
// that answers from the truth within 1.5 m.
class ScriptedDrive {
 public:
  explicit ScriptedDrive(MapperOptions o, double registration_variance = 1e-4)
      : mapper_(o), registration_variance_(registration_variance) {
    floor_t f{};
    f.floor_index = 0;
    EXPECT_TRUE(mapper_.onFloor(f));
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
  // Only the next `n` global searches find a place (by appearance); later ones find none,
  // node-mode requests still register (-1: every search finds one).
  void globalSearchesFind(int n) { global_finds_ = n; }
  // Steps `dy` metres sideways (along y), heading kept, VO seeing it.
  void sidestep(double dy) { frame(SE3d(pose_.so3(), pose_.translation() + Vec3(0, dy, 0))); }
  // The robot slides `dx` metres along x without VO seeing it (a wheel slip VO missed, a
  // kidnapping): VO reports no motion, with its usual confidence.
  void slip(double dx) {
    utime_ += 100000;
    const SE3d next(pose_.so3(), pose_.translation() + Vec3(dx, 0, 0));
    EXPECT_TRUE(mapper_.onVo(voMsg(utime_, utime_ - 100000, SE3d(), 1e-3, true)));
    pose_ = next;
    truth_[utime_] = next;
    answer();
  }
  const SE3d& truePose() const { return pose_; }
  // A repeated texture: from now on registrations see the robot `dx` metres further along x
  // than it is (0: the truth again).
  void aliasBy(double dx) { alias_dx_ = dx; }
  // The true body pose at a node's keyframe.
  const SE3d& nodeTruth(int64_t id) const { return node_truth_.at(id); }
  Mapper& mapper() { return mapper_; }
  // An elevator ride that ends where it started, on floor `index`, whose height estimate says
  // `height_m` with standard deviation `sigma_m`.
  void rideEnd(int index, double height_m, double sigma_m) {
    floor_t f{};
    f.utime = utime_;
    f.floor_index = index;
    f.height_m = height_m;
    f.height_sigma_m = sigma_m;
    f.event = floor_t::EVENT_RIDE_END;
    EXPECT_TRUE(mapper_.onFloor(f));
  }
  // The robot is off for `seconds` and starts again where it stopped, VO from a new
  // keyframe; the new session's FLOOR message arrives only when `announce`.
  void newSession(double seconds, bool announce) {
    utime_ += static_cast<int64_t>(seconds * 1e6);
    if (announce) {
      floor_t f{};
      f.utime = utime_;
      f.floor_index = 0;
      EXPECT_TRUE(mapper_.onFloor(f));
    }
    utime_ += 100000;
    EXPECT_TRUE(mapper_.onVo(voRestart(utime_)));
    truth_[utime_] = pose_;
    answer();
  }

 private:
  static double yawOf(const SE3d& p) { return core::toPlanar(p).theta(); }
  void frame(const SE3d& next) {
    utime_ += 100000;
    if (truth_.empty()) {
      EXPECT_TRUE(mapper_.onVo(voRestart(utime_)));
    } else {
      EXPECT_TRUE(mapper_.onVo(voMsg(utime_, utime_ - 100000, pose_.inverse() * next, 1e-3, true)));
    }
    pose_ = next;
    truth_[utime_] = next;
    answer();
  }
  void answer() {
    for (int guard = 0; guard < 4; ++guard) {
      for (const auto& n : mapper_.takeNodesAdded()) node_truth_[n.node_id] = truth_.at(n.keyframe_utime);
      const auto requests = mapper_.takeRequests();
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
          EXPECT_TRUE(mapper_.onRegisterResult(res));
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
          for (int i = 0; i < 3; ++i) res.translation[i] = rel.translation()[i];
          const auto& qq = rel.quaternion();
          res.orientation[0] = qq.w();
          res.orientation[1] = qq.x();
          res.orientation[2] = qq.y();
          res.orientation[3] = qq.z();
          for (int i = 0; i < 6; ++i) res.covariance[7 * i] = registration_variance_;
        }
        EXPECT_TRUE(mapper_.onRegisterResult(res));
      }
    }
  }

  Mapper mapper_;
  double registration_variance_;
  double alias_dx_ = 0.0;
  bool blind_ = false;
  int global_finds_ = -1;
  SE3d pose_;
  int64_t utime_ = 0;
  std::map<int64_t, SE3d> truth_;
  std::map<int64_t, SE3d> node_truth_;
};

MapperOptions scriptedOptions() {
  MapperOptions o;
  o.tracker.body_T_cam = SE3d();
  o.step_interval_s = 0.3;
  return o;
}

void lap(ScriptedDrive& drive) {
  drive.driveTo(8.0, 0.0);
  drive.driveTo(8.0, std::numbers::pi);
  drive.driveTo(0.0, std::numbers::pi);
  drive.driveTo(0.0, 0.0);
}

TEST(ReducedGraph, RevisitAddsConstraintNotNode) {
  ScriptedDrive drive(scriptedOptions());
  lap(drive);
  const int64_t nodes_after_first = drive.mapper().stats().nodes;
  const int64_t constraints_after_first = drive.mapper().stats().constraints;
  const int64_t closures_after_first = drive.mapper().stats().loop_closures;
  ASSERT_GT(nodes_after_first, 10);
  lap(drive);
  // The turns' steps come at other headings each lap: one may fall between two of the first
  // lap's nodes, more than the overlap (45°) from both. Once covered, no more.
  EXPECT_LE(drive.mapper().stats().nodes, nodes_after_first + 2);
  const int64_t nodes_after_second = drive.mapper().stats().nodes;
  lap(drive);
  EXPECT_EQ(drive.mapper().stats().nodes, nodes_after_second);
  EXPECT_GT(drive.mapper().stats().constraints, constraints_after_first);
  EXPECT_GT(drive.mapper().stats().loop_closures, closures_after_first);
  EXPECT_EQ(drive.mapper().stats().rejected_inconsistent, 0);
  // Exact measurements: the map is exact. The origin is the first frame, 0.1 m along x.
  const SE3d end = drive.mapper().pose().mean;
  EXPECT_LT((end.translation() - Vec3(-0.1, 0, 0)).norm(), 1e-6);
  EXPECT_LT(core::rotationAngle(end.so3()), 1e-6);
}

// A lap, then the corridor again 0.2 m to the side, where registrations fail (a dark
// stretch): the map's frame is the first node's, so the first line is at y = 0 and the
// second across the cell edge there, within the overlap of the first's nodes (about 1.5 m
// apart). The nodes the dark pass adds.
int64_t nodesAddedAcrossACellEdge(const MapperOptions& o) {
  ScriptedDrive drive(o);
  drive.sidestep(0.3);
  lap(drive);
  const int64_t before = drive.mapper().stats().nodes;
  EXPECT_GT(before, 10);
  drive.sidestep(-0.2);
  drive.blind(true);
  drive.driveTo(8.0, 0.0);
  return drive.mapper().stats().nodes - before;
}

TEST(ReducedGraph, APlaceSeenAcrossACellEdgeAddsNoNodeWhileAnotherOverlapsIt) {
  MapperOptions cells_only = scriptedOptions();
  cells_only.overlap_radius_cells = 0.0;
  cells_only.overlap_heading_sectors = 0.0;
  // Eq. 8 alone: every cell on the new line is empty, a node each.
  EXPECT_GE(nodesAddedAcrossACellEdge(cells_only), 5);
  // With the overlap (the defaults): the nodes 0.5 m away are the same place.
  EXPECT_EQ(nodesAddedAcrossACellEdge(scriptedOptions()), 0);
  MapperOptions bad = scriptedOptions();
  bad.overlap_radius_cells = 2.0;  // more than a cell: the neighbouring cells would not hold it
  EXPECT_FALSE(bad.validate());
  bad = scriptedOptions();
  bad.overlap_heading_sectors = 1.5;  // more than a sector
  EXPECT_FALSE(bad.validate());
}

TEST(ReducedGraph, AClosureTheMapAlreadyHoldsReLocalisesWithoutAFactor) {
  auto run = [](double min_information) {
    MapperOptions o = scriptedOptions();
    o.min_closure_information = min_information;
    ScriptedDrive drive(o);
    for (int k = 0; k < 3; ++k) lap(drive);
    return std::make_pair(drive.mapper().stats(), drive.mapper().pose().mean);
  };
  const auto [all, all_end] = run(0.0);
  const auto [informative, informative_end] = run(1e3);  // no closure tells the map 1000 nats
  EXPECT_EQ(all.closures_uninformative, 0);
  EXPECT_GT(informative.closures_uninformative, 0);
  EXPECT_EQ(informative.nodes, all.nodes);
  EXPECT_LT(informative.factors, all.factors);
  // Re-localised on the nodes all the same: exact measurements, an exact pose.
  EXPECT_LT((informative_end.translation() - all_end.translation()).norm(), 1e-6);
  MapperOptions bad = scriptedOptions();
  bad.min_closure_information = -1.0;
  EXPECT_FALSE(bad.validate());
}

TEST(ReducedGraph, AnElevatorRideMovesTheEstimateToTheNewFloorAndTakesNoStepInTheCab) {
  // elevator-proc announces no floor before the first ride: its start names the height of
  // the floor left. Keyframes in the cab take no step (the cab is a place that moves), and
  // the ride's end moves the estimate to the new floor's height.
  Mapper m(scriptedOptions());
  ASSERT_TRUE(m.onVo(voRestart(0)));
  ASSERT_EQ(m.nodes().size(), 1u);
  floor_t start{};
  start.utime = 1'000'000;
  start.floor_index = -1;
  start.height_m = 0.0;
  start.height_sigma_m = 0.05;
  start.in_elevator = 1;
  start.event = floor_t::EVENT_RIDE_START;
  ASSERT_TRUE(m.onFloor(start));
  const int64_t steps = m.stats().steps;
  for (int k = 1; k <= 5; ++k)
    ASSERT_TRUE(m.onVo(voMsg(1'000'000 + k * 600'000, k == 1 ? 0 : 1'000'000 + (k - 1) * 600'000, SE3d(), 1e-3, true)));
  EXPECT_EQ(m.stats().steps, steps);
  floor_t end = start;
  end.utime = 5'000'000;
  end.floor_index = 1;
  end.height_m = -4.7;
  end.in_elevator = 0;
  end.event = floor_t::EVENT_RIDE_END;
  end.new_floor = 1;
  ASSERT_TRUE(m.onFloor(end));
  EXPECT_NEAR(m.pose().mean.translation().z(), -4.7, 1e-6);
  EXPECT_EQ(m.floor(), 1);
  ASSERT_EQ(m.floors().size(), 2u);
  EXPECT_EQ(m.floors().at(0), 0.0);
  EXPECT_EQ(m.floors().at(1), -4.7);
}

TEST(ReducedGraph, ARideEndsOnTheMapsFloorAtItsHeightWhateverElevatorProcCallsIt) {
  // A map with floors 0 (0 m) and 1 (-4.7 m). A new session's elevator-proc starts its own
  // table on floor 0 and calls the first floor it rides to "floor 1" wherever it is: up at
  // +4.7 m that is a floor the map does not have (a new label, 2); down at -4.6 m it is the
  // map's floor 1.
  for (const double ride_m : {4.7, -4.6}) {
    Mapper m(scriptedOptions());
    ASSERT_TRUE(m.onVo(voRestart(0)));
    floor_t start{};
    start.utime = 1'000'000;
    start.floor_index = -1;
    start.height_sigma_m = 0.05;
    start.in_elevator = 1;
    start.event = floor_t::EVENT_RIDE_START;
    ASSERT_TRUE(m.onFloor(start));
    floor_t end = start;
    end.utime = 5'000'000;
    end.floor_index = 1;
    end.height_m = -4.7;
    end.in_elevator = 0;
    end.event = floor_t::EVENT_RIDE_END;
    ASSERT_TRUE(m.onFloor(end));
    ASSERT_EQ(m.floor(), 1);
    // Back to floor 0, then the new session's ride, labelled 1 by its elevator-proc.
    start.utime = 6'000'000;
    start.height_m = -4.7;
    ASSERT_TRUE(m.onFloor(start));
    end.utime = 9'000'000;
    end.floor_index = 0;
    end.height_m = 0.05;
    ASSERT_TRUE(m.onFloor(end));
    ASSERT_EQ(m.floor(), 0);
    start.utime = 10'000'000;
    start.height_m = 0.0;
    ASSERT_TRUE(m.onFloor(start));
    end.utime = 14'000'000;
    end.floor_index = 1;
    end.height_m = ride_m;
    end.new_floor = 1;
    ASSERT_TRUE(m.onFloor(end));
    EXPECT_EQ(m.floor(), ride_m > 0 ? 2 : 1) << ride_m;
  }
}

TEST(FullGraph, AddsANodeAtEveryStepThroughTheSameCode) {
  MapperOptions o = scriptedOptions();
  o.full_graph = true;
  ScriptedDrive drive(o);
  lap(drive);
  const int64_t first = drive.mapper().stats().nodes;
  lap(drive);
  EXPECT_EQ(drive.mapper().stats().nodes, drive.mapper().stats().steps);
  EXPECT_GT(drive.mapper().stats().nodes, first + 10);
}

TEST(ReducedGraph, ActiveNodeRegistrationReplacesDeltaOnlyWhenItIsMoreCertain) {
  // The paper's entropy test instead of the fusion.
  MapperOptions o = scriptedOptions();
  o.fuse_active_registration = false;
  // Registrations far more certain than VO (variance 1e-12 against 1e-6 per frame): every
  // registration to the active node wins the det(Σ) test.
  ScriptedDrive sharp(o, 1e-12);
  lap(sharp);
  const auto& a = sharp.mapper().stats();
  EXPECT_GT(a.delta_replaced, 10);
  EXPECT_EQ(a.delta_fused, 0);
  // Registrations far less certain (variance 1): Δ is kept, except for the one forced
  // re-localisation after each loop closure.
  ScriptedDrive blurred(o, 1.0);
  lap(blurred);
  const auto& b = blurred.mapper().stats();
  EXPECT_GT(b.delta_kept, 10);
  EXPECT_LE(b.delta_replaced, b.loop_closures);
}

TEST(ReducedGraph, RecoversWhenTwoRegistrationsAgreeAgainstAWrongDelta) {
  // A mapped corridor, then an unseen 0.6 m slip: Δ (confident, wrong) contradicts every
  // registration. The first is rejected as a possible false match; the second agrees with it
  // through odometry, so Δ is what was wrong. Without that the mapper would reject every
  // later registration and add nodes over the mapped corridor.
  ScriptedDrive drive(scriptedOptions(), 1e-6);
  lap(drive);
  drive.driveTo(3.0, 0.0);
  const size_t nodes_before = drive.mapper().nodes().size();
  drive.slip(0.6);
  drive.driveTo(8.0, 0.0);
  drive.driveTo(8.0, std::numbers::pi);
  drive.driveTo(0.0, std::numbers::pi);
  const auto& s = drive.mapper().stats();
  EXPECT_GE(s.rejected_map_gate, 1);
  EXPECT_GE(s.gate_recoveries, 1);
  EXPECT_LE(drive.mapper().nodes().size(), nodes_before + 1);
  // The map's origin is the first frame, 0.1 m along x.
  const SE3d estimate = drive.mapper().pose().mean;
  EXPECT_LT((estimate.translation() - (drive.truePose().translation() - Vec3(0.1, 0, 0))).norm(), 0.05);
}

TEST(ReducedGraph, RegistrationsThatAgreeOnAPlaceOneTexturePeriodAwayDoNotMoveTheRobot) {
  // A floor pattern that repeats every 12 m: on a mapped 16 m corridor, every registration of
  // the robot's first 4 m places it 12 m further on, and they agree with each other through
  // odometry. The gate rejects them; a recovery would jump the robot 12 m, far more than
  // odometry can have drifted in 4 m since the last confirmed registration.
  for (const bool bounded : {true, false}) {
    MapperOptions o = scriptedOptions();
    if (!bounded) o.recovery_slack_m = 1e9;  // the recovery without the drift bound
    ScriptedDrive drive(o, 1e-6);
    drive.driveTo(16.0, 0.0);
    drive.driveTo(16.0, std::numbers::pi);
    drive.driveTo(0.0, std::numbers::pi);
    drive.driveTo(0.0, 0.0);
    drive.aliasBy(12.0);
    drive.driveTo(4.0, 0.0);
    const auto& s = drive.mapper().stats();
    const SE3d estimate = drive.mapper().pose().mean;
    const double error_m = (estimate.translation() - (drive.truePose().translation() - Vec3(0.1, 0, 0))).norm();
    if (bounded) {
      EXPECT_GE(s.rejected_map_gate, 2);
      EXPECT_GE(s.recoveries_too_far, 1);
      EXPECT_EQ(s.gate_recoveries, 0);
      EXPECT_LT(error_m, 0.05);
    } else {
      EXPECT_GE(s.gate_recoveries, 1);
      EXPECT_GT(error_m, 10.0);  // what the bound prevents
    }
  }
}

TEST(ReducedGraph, AGateRecoveryToAnotherNodeAddsNoClosureFromTheWrongDelta) {
  // A 2 m slip VO does not see: the active node's cell has nothing to register to, the global
  // search finds the node 2 m on. The map gate rejects a_T_b (Δ says 0 m, the map 2 m), and the
  // second registration agrees with the first: the recovery. A closure a → b from Δ would pull
  // the corridor 2 m together; the robot is placed at b instead.
  ScriptedDrive drive(scriptedOptions(), 1e-6);
  lap(drive);
  drive.driveTo(3.0, 0.0);
  drive.slip(2.0);
  drive.driveTo(8.0, 0.0);
  EXPECT_GE(drive.mapper().stats().gate_recoveries, 1);
  for (const auto& c : drive.mapper().constraints().all()) {
    if (!c.accepted || c.kind != ConstraintKind::kLoop) continue;
    const SE3d truth = drive.nodeTruth(c.from).inverse() * drive.nodeTruth(c.to);
    EXPECT_LT((c.from_T_to.mean.translation() - truth.translation()).norm(), 0.05) << c.from << " -> " << c.to;
  }
  const SE3d estimate = drive.mapper().pose().mean;
  EXPECT_LT((estimate.translation() - (drive.truePose().translation() - Vec3(0.1, 0, 0))).norm(), 0.05);
}

TEST(ReducedGraph, ActiveNodeRegistrationIsFusedWithDeltaExceptToReLocalise) {
  MapperOptions o = scriptedOptions();
  o.fuse_active_registration = true;
  for (const double variance : {1e-12, 1e-4, 1.0}) {
    ScriptedDrive drive(o, variance);
    lap(drive);
    lap(drive);
    const auto& s = drive.mapper().stats();
    EXPECT_GT(s.delta_fused, 10) << variance;
    EXPECT_EQ(s.delta_kept, 0) << variance;
    // Replaced only by the re-localisation that follows a loop closure.
    EXPECT_LE(s.delta_replaced, s.loop_closures) << variance;
    // Exact measurements fused stay exact, whatever their weights.
    const SE3d end = drive.mapper().pose().mean;
    EXPECT_LT((end.translation() - Vec3(-0.1, 0, 0)).norm(), 1e-6) << variance;
    EXPECT_LT(core::rotationAngle(end.so3()), 1e-6) << variance;
  }
}

TEST(ConstraintSet, FusesTwoEstimatesByTheirInformation) {
  const Mat6 cov = Mat6::Identity() * 1e-2;
  const UncertainPose a{planar(0.0, 0.0, 0.0), cov};
  const UncertainPose b{planar(0.2, 0.0, 0.0), cov};
  const UncertainPose ab = ConstraintSet::fuse(a, b);
  EXPECT_LT((ab.mean.translation() - Vec3(0.1, 0, 0)).norm(), 1e-12);
  EXPECT_LT((ab.covariance - 0.5 * cov).norm(), 1e-12);
  // Four times the variance: a fifth of the weight.
  const UncertainPose c = ConstraintSet::fuse(a, UncertainPose{b.mean, 4.0 * cov});
  EXPECT_NEAR(c.mean.translation().x(), 0.04, 1e-12);
  EXPECT_LT((c.covariance - 0.8 * cov).norm(), 1e-12);
}

TEST(ReducedGraph, NodesOfAFloorAreHeldAtTheFloorsFirstHeightNotAtEachRidesEstimate) {
  ScriptedDrive drive(scriptedOptions());
  lap(drive);
  // Back on floor 0 from a ride whose estimate is 0.5 m off, with σ = 1 m.
  drive.rideEnd(0, 0.5, 1.0);
  const size_t before = drive.mapper().nodes().size();
  drive.driveTo(20.0, 0.0);
  ASSERT_GT(drive.mapper().nodes().size(), before + 5);
  EXPECT_EQ(drive.mapper().floors().at(0), 0.0);
  for (size_t id = before; id < drive.mapper().nodes().size(); ++id)
    EXPECT_LT(std::abs(drive.mapper().nodePose(static_cast<int64_t>(id)).translation().z()), 0.01) << id;
}

TEST(Mapper, ALongGapInVoStartsOneSessionEvenWhenItsFloorMessageIsLost) {
  for (const bool announce : {true, false}) {
    ScriptedDrive drive(scriptedOptions());
    lap(drive);
    ASSERT_EQ(drive.mapper().session(), 0);
    const int64_t nodes = drive.mapper().stats().nodes;
    drive.newSession(3600.0, announce);
    EXPECT_EQ(drive.mapper().session(), 1) << "FLOOR sent: " << announce;
    EXPECT_TRUE(drive.mapper().lost());
    lap(drive);
    // Re-localised by global registrations, the second session maps nothing new.
    EXPECT_FALSE(drive.mapper().lost()) << "FLOOR sent: " << announce;
    EXPECT_EQ(drive.mapper().session(), 1);
    EXPECT_EQ(drive.mapper().stats().nodes, nodes);
  }
}

// A session starts where the map has a place, but the global search finds it (by
// appearance) only once, in the first seconds: the candidate placement is checked by a
// node-mode request where it says the robot is, and the session is placed on the map;
// waiting for a second global match, it stays lost.
TEST(Mapper, ALostRobotChecksItsCandidatePlacementAgainstTheNodeWhereItPredictsItIs) {
  for (const int checks : {2, 0}) {
    MapperOptions o = scriptedOptions();
    o.relocalization_checks = checks;
    ScriptedDrive drive(o);
    lap(drive);
    const int64_t nodes = drive.mapper().stats().nodes;
    drive.globalSearchesFind(1);
    drive.newSession(3600.0, true);
    lap(drive);
    if (checks > 0) {
      EXPECT_FALSE(drive.mapper().lost());
      EXPECT_EQ(drive.mapper().stats().relocalizations, 1);
      // Placed on the lap it mapped: not a second copy of it (a step whose cell is empty
      // may still add one, its global search finding nothing).
      EXPECT_LE(drive.mapper().stats().nodes, nodes + 2);
    } else {
      EXPECT_TRUE(drive.mapper().lost());
      EXPECT_EQ(drive.mapper().stats().relocalizations, 0);
    }
  }
}

// The check that needs no motion: the candidate's own keyframe registered against a node the
// map links to the candidate's node. A session that starts on a mapped place is placed at its
// first keyframe, before it moves (the checks at later keyframes came too late live: a robot
// starting slowly makes its next keyframe seconds later, past the place).
TEST(Mapper, ALostRobotChecksItsCandidateOnTheSameKeyframeAgainstALinkedNode) {
  ScriptedDrive drive(scriptedOptions());
  lap(drive);
  // Between nodes 0 (x = 0.1 m) and 1 (1.6 m): the oracle registers to either (< 1.5 m).
  drive.driveTo(0.8, 0.0);
  drive.newSession(3600.0, true);
  EXPECT_FALSE(drive.mapper().lost());
  EXPECT_EQ(drive.mapper().stats().relocalizations, 1);
  EXPECT_EQ(drive.mapper().stats().relocalization_same_frame_checks, 1);
  EXPECT_EQ(drive.mapper().stats().relocalization_disagreements, 0);
  // Placed where it is: the next lap adds no copy of the corridor.
  const int64_t nodes = drive.mapper().stats().nodes;
  lap(drive);
  EXPECT_LE(drive.mapper().stats().nodes, nodes + 2);
}

TEST(Mapper, DropsMalformedAndStaleMessagesAndCountsThem) {
  Mapper m(scriptedOptions());
  register_result_t stale{};
  stale.request_id = 42;
  EXPECT_FALSE(m.onRegisterResult(stale));
  attitude_t a{};
  a.utime = 10;
  a.roll_rad = std::nan("");
  EXPECT_FALSE(m.onAttitude(a));
  floor_t f{};
  f.height_m = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(m.onFloor(f));
  EXPECT_EQ(m.stats().dropped, 3);
  EXPECT_EQ(m.stats().nodes, 0);
}

TEST(MapStore, SavesOneTransactionPerUpdateAndReloadsEveryNodeAndEdge) {
  evermap::testing::ScratchDir dir;
  const auto file = dir.path() / "map.db";
  ScriptedDrive drive(scriptedOptions());
  const MapStoreOptions every_row{0};  // no folds: each constraint is its own row
  {
    auto store = MapStore::open(file, every_row);
    ASSERT_TRUE(store) << store.error().message;
    lap(drive);
    ASSERT_TRUE(store->save(drive.mapper(), 0, 0));
    lap(drive);
    ASSERT_TRUE(store->save(drive.mapper(), 0, 0));
  }
  // Reopened: nothing is stored twice, and a further update appends.
  auto store = MapStore::open(file, every_row);
  ASSERT_TRUE(store) << store.error().message;
  ASSERT_TRUE(store->save(drive.mapper(), 0, 0));
  ASSERT_TRUE(store->integrityCheck());
  // Each save ends with a checkpoint: the map is in the file, the write-ahead log is empty.
  std::error_code ec;
  const auto wal_bytes = std::filesystem::file_size(file.string() + "-wal", ec);
  EXPECT_TRUE(ec || wal_bytes == 0) << wal_bytes << " bytes left in the log";
  auto snap = store->load();
  ASSERT_TRUE(snap) << snap.error().message;
  const Mapper& m = drive.mapper();
  ASSERT_EQ(snap->nodes.size(), m.nodes().size());
  ASSERT_EQ(snap->edges.size(), m.constraints().all().size());
  ASSERT_EQ(snap->sessions.size(), 1u);
  ASSERT_EQ(snap->floors.size(), 1u);
  for (const StoredNode& n : snap->nodes) {
    EXPECT_LT((n.world_T_body.inverse() * m.nodePose(n.node.id)).log().norm(), 1e-12);
    EXPECT_EQ(n.node.keyframe_utime, m.nodes()[n.node.id].keyframe_utime);
  }
  for (const StoredEdge& e : snap->edges) {
    const Constraint& c = m.constraints().all()[e.edge_id];
    EXPECT_EQ(e.constraint.from, c.from);
    EXPECT_EQ(e.constraint.to, c.to);
    EXPECT_EQ(e.constraint.accepted, c.accepted);
    EXPECT_LT((e.constraint.from_T_to.covariance - c.from_T_to.covariance).norm(), 1e-15);
  }
}

TEST(MapStore, FoldsAPairsConstraintsSoTheStoreGrowsWithTheMapNotWithTheTime) {
  // The same corridor, lap after lap: nodes stop growing after the first lap, constraints do
  // not. Unfolded, every one is a row for ever; folded, a pair keeps one row.
  evermap::testing::ScratchDir dir;
  ScriptedDrive drive(scriptedOptions());
  auto folded = MapStore::open(dir.path() / "folded.db");  // fold_after = 2
  auto plain = MapStore::open(dir.path() / "plain.db", MapStoreOptions{0});
  ASSERT_TRUE(folded && plain);
  std::vector<size_t> folded_rows, plain_rows;
  for (int k = 0; k < 8; ++k) {
    // A pause long enough to start a new session in the same mapper half-way.
    if (k == 4) drive.newSession(60.0, true);
    lap(drive);
    ASSERT_TRUE(folded->save(drive.mapper(), 0, 0));
    ASSERT_TRUE(plain->save(drive.mapper(), 0, 0));
    folded_rows.push_back(folded->load()->edges.size());
    plain_rows.push_back(plain->load()->edges.size());
  }
  const Mapper& m = drive.mapper();
  const size_t pairs = m.constraints().pairs().size();
  EXPECT_EQ(plain_rows.back(), m.constraints().all().size());
  EXPECT_GT(plain_rows.back(), plain_rows[1] + 30);  // grows with the time
  // Grows with the pairs: one row each, beside the rows of rejected constraints whose pair
  // holds no accepted one (not a pair of the map, never folded).
  int64_t rejected = 0;
  for (const Constraint& c : m.constraints().all()) rejected += c.accepted ? 0 : 1;
  EXPECT_LE(folded_rows.back(), pairs + static_cast<size_t>(rejected));
  EXPECT_LE(folded_rows.back(), folded_rows[1] + 2);
  // The pages folds freed went back to the file system: the file is the map.
  {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open_v2((dir.path() / "folded.db").c_str(), &db, SQLITE_OPEN_READONLY, nullptr), SQLITE_OK);
    sqlite3_stmt* st = nullptr;
    ASSERT_EQ(sqlite3_prepare_v2(db, "PRAGMA freelist_count", -1, &st, nullptr), SQLITE_OK);
    ASSERT_EQ(sqlite3_step(st), SQLITE_ROW);
    EXPECT_EQ(sqlite3_column_int64(st, 0), 0);
    sqlite3_finalize(st);
    sqlite3_close(db);
  }
  ASSERT_TRUE(folded->integrityCheck());
  auto snap = folded->load();
  ASSERT_TRUE(snap);
  EXPECT_EQ(snap->constraintsRepresented(), static_cast<int64_t>(m.constraints().all().size()));

  // Restored, the folded store gives every pair the estimate the live mapper had merged.
  Mapper restored{scriptedOptions()};
  ASSERT_TRUE(restored.restore(*snap));
  ASSERT_EQ(restored.constraints().pairs().size(), pairs);
  for (const auto& [key, pair] : m.constraints().pairs()) {
    const auto it = restored.constraints().pairs().find(key);
    ASSERT_NE(it, restored.constraints().pairs().end());
    EXPECT_LT((pair.i_T_j.mean.inverse() * it->second.i_T_j.mean).log().norm(), 1e-9) << key.first << "-" << key.second;
    EXPECT_LT((pair.i_T_j.covariance - it->second.i_T_j.covariance).norm(), 1e-9 * pair.i_T_j.covariance.norm());
  }
  // Nothing of the current mapper is stored twice by a store opened anew.
  auto reopened = MapStore::open(dir.path() / "folded.db");
  ASSERT_TRUE(reopened && reopened->save(drive.mapper(), 0, 0));
  EXPECT_EQ(reopened->load()->edges.size(), folded_rows.back());
}

TEST(MapStore, RejectsAFileThatIsNotAMapStore) {
  evermap::testing::ScratchDir dir;
  const auto file = dir.path() / "junk.db";
  {
    std::ofstream out(file);
    out << "this is not sqlite";
  }
  auto store = MapStore::open(file);
  ASSERT_FALSE(store);
  EXPECT_NE(store.error().message.find("junk.db"), std::string::npos);
}

sim::SimOptions shortPatrol() {
  sim::SimOptions o = sim::testing::smallBuilding(7);
  o.patrol.sessions = 1;
  o.patrol.total_hours = 0.05;
  o.patrol.span_days = 1;
  o.patrol.explore_sessions = 1;
  return o;
}

TEST(ReducedGraph, HasFarFewerNodesThanTheFullGraphWithComparableAccuracy) {
  MapperOptions reduced_options;
  MapperOptions full_options;
  full_options.full_graph = true;
  evermap::testing::ScratchDir dir;
  auto reduced = runOffline(shortPatrol(), reduced_options, dir.path() / "map.db");
  auto full = runOffline(shortPatrol(), full_options);
  ASSERT_TRUE(reduced) << reduced.error().message;
  ASSERT_TRUE(full) << full.error().message;
  EXPECT_EQ(reduced->step_poses, full->step_poses);
  EXPECT_LT(reduced->nodes * 5, full->nodes);
  EXPECT_GT(reduced->stats.loop_closures, 10);
  EXPECT_EQ(reduced->decode_errors, 0);
  EXPECT_EQ(reduced->stats.dropped, 0);
  // Comparable accuracy: a few decimetres over ~300 m, and within 2.5x of the full graph.
  EXPECT_LT(reduced->ate_rmse_m, 0.5);
  EXPECT_LT(full->ate_rmse_m, 0.5);
  EXPECT_LT(reduced->ate_rmse_m, 2.5 * full->ate_rmse_m);
  // The map store holds the final map: every node, and every constraint (some folded).
  auto store = MapStore::open(dir.path() / "map.db");
  ASSERT_TRUE(store);
  auto snap = store->load();
  ASSERT_TRUE(snap);
  EXPECT_EQ(static_cast<int64_t>(snap->nodes.size()), reduced->nodes);
  EXPECT_EQ(snap->constraintsRepresented(), reduced->constraints);
  EXPECT_GT(reduced->store_transactions, reduced->nodes);
}

}  // namespace
}  // namespace evermap::mapper
