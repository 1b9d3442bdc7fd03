// mapper-proc: the tracker (eq. 6-7) and the constraint set.

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>
#include <numbers>

#include "core/geometry/se2.h"
#include "core/messages/odometry_frame.h"
#include "mapper-proc/constraint_set.h"
#include "mapper-proc/tracker.h"
#include "tests/mapper_messages.h"

namespace evermap::mapper {
namespace {

using namespace testing;  // tests/mapper_messages.h

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
  w.delta_x_m = 3.0;
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

TEST(Tracker, RefusesOdometryFasterThanPhysicsAllowsAndKeepsItsEstimate) {
  TrackerOptions o;
  o.max_speed_m_s = 10.0;
  o.max_turn_rad_s = 5.0;
  Tracker t(o);
  ASSERT_TRUE(t.addVo(voRestart(0)));
  ASSERT_TRUE(t.addVo(voMsg(100000, 0, planar(0.9, 0, 0.4), 1e-3, false)));  // 9 m/s, 4 rad/s
  const SE3d before = t.delta().mean;
  // Motion since the reference, 0.2 s before: 2.1 m, 10.5 m/s.
  const Status fast = t.addVo(voMsg(200000, 0, planar(2.1, 0, 0), 1e-3, false));
  ASSERT_FALSE(fast);
  EXPECT_NE(fast.error().message.find("tracker.max_speed_m_s"), std::string::npos)
      << fast.error().message;
  // 1.1 rad in 0.2 s: 5.5 rad/s.
  const Status turn = t.addVo(voMsg(200000, 0, planar(0.1, 0, 1.1), 1e-3, false));
  ASSERT_FALSE(turn);
  EXPECT_NE(turn.error().message.find("tracker.max_turn_rad_s"), std::string::npos)
      << turn.error().message;
  // The hostile message's 1e9 m over the whole span since the reference.
  EXPECT_FALSE(t.addVo(voMsg(300000, 0, planar(1e9, 0, 0), 1e-3, false)));
  EXPECT_EQ(t.counts().implausible, 3);
  EXPECT_EQ(t.counts().dropped, 3);
  EXPECT_LT((t.delta().mean.inverse() * before).log().norm(), 1e-15);
  // A plausible frame after them is used.
  ASSERT_TRUE(t.addVo(voMsg(300000, 0, planar(1.5, 0, 0.5), 1e-3, false)));  // 5 m/s over 0.3 s
  EXPECT_NEAR(t.delta().mean.translation().x(), 1.5, 1e-12);

  // Wheel odometry, while VO is down: 2 m in 0.1 s is refused, a zero-length span counts as
  // 1 ms.
  vo_delta_t fail = voMsg(400000, 300000, SE3d(), 0, false);
  fail.status = vo_delta_t::STATUS_INSUFFICIENT_FEATURES;
  ASSERT_TRUE(t.addVo(fail));
  ASSERT_FALSE(t.voTracking());
  const Eigen::Vector3d at = t.delta().mean.translation();
  EXPECT_FALSE(t.addWheel(wheelMsg(400000, 500000, 2.0)));
  EXPECT_FALSE(t.addWheel(wheelMsg(500000, 500000, 0.5)));
  ASSERT_TRUE(t.addWheel(wheelMsg(400000, 500000, 0.5)));
  EXPECT_EQ(t.counts().implausible, 5);
  EXPECT_NEAR((t.delta().mean.translation() - at).norm(), 0.5, 1e-9);  // forward, turned
}

TEST(TrackerOptions, RefusesNonPositiveOrNonFiniteMotionBounds) {
  TrackerOptions o;
  EXPECT_TRUE(o.validate());
  o.max_speed_m_s = 0.0;
  EXPECT_FALSE(o.validate());
  o.max_speed_m_s = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(o.validate());
  o = TrackerOptions{};
  o.max_turn_rad_s = std::nan("");
  EXPECT_FALSE(o.validate());
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
  for (int k = 2; k <= 11; ++k)
    ASSERT_TRUE(t.addWheel(wheelMsg((k - 1) * 100000, k * 100000, 0.1, 1e-6)));
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

// A turn, 2 degrees and 5 cm a frame at 20 Hz, a keyframe every third frame, stamped with
// odometry poses as vo-proc stamps it.
std::vector<vo_delta_t> turnStream(int frames, double variance = 1e-3) {
  messages::OdometryFrame odometry;
  std::vector<vo_delta_t> stream{voRestart(0)};
  odometry.stamp(stream.back());
  const SE3d step = planar(0.05, 0.0, 2.0 * std::numbers::pi / 180.0);
  int64_t ref = 0;
  SE3d ref_T_cur;
  for (int k = 1; k <= frames; ++k) {
    ref_T_cur = ref_T_cur * step;
    const bool keyframe = k % 3 == 0;
    stream.push_back(voMsg(k * 50'000, ref, ref_T_cur, variance, keyframe));
    odometry.stamp(stream.back());
    if (keyframe) {
      ref = k * 50'000;
      ref_T_cur = SE3d();
    }
  }
  return stream;
}

TEST(Tracker, ALostKeyframeChangeIsBridgedByTheOdometryPosesNotByTheEstimate) {
  // A lossy link lost the VO_DELTA of keyframe 6 (its keyframe change): frame 7 names a
  // reference the tracker never saw. Its odometry pose and frame 5's give the motion between
  // them exactly; without them (an old sender) frame 7 sits where frame 5 was, two frames'
  // motion behind (4 degrees in this turn), for good.
  const std::vector<vo_delta_t> stream = turnStream(12);
  Tracker all(TrackerOptions{});
  for (const vo_delta_t& m : stream) ASSERT_TRUE(all.addVo(m));
  Tracker bridged(TrackerOptions{}), unbridged(TrackerOptions{});
  for (const vo_delta_t& m : stream) {
    if (m.utime == 6 * 50'000) continue;
    ASSERT_TRUE(bridged.addVo(m));
    vo_delta_t old = m;
    old.odom_epoch = 0;
    ASSERT_TRUE(unbridged.addVo(old));
  }
  EXPECT_EQ(bridged.counts().reanchored, 1);
  EXPECT_EQ(bridged.counts().odometry_bridged, 1);
  EXPECT_EQ(unbridged.counts().odometry_bridged, 0);
  const auto yaw_error = [&](const Tracker& t) {
    return std::abs(core::toPlanar(t.delta().mean.inverse() * all.delta().mean).theta());
  };
  EXPECT_LT((bridged.delta().mean.inverse() * all.delta().mean).log().norm(), 1e-9);
  EXPECT_NEAR(yaw_error(unbridged), 4.0 * std::numbers::pi / 180.0, 1e-9);
  // Δ's covariance holds the bridged motion's.
  EXPECT_GT(bridged.delta().covariance.trace(), unbridged.delta().covariance.trace());
  // A pose that lies (100 m in 0.1 s) bridges nothing: the frame goes where the estimate is.
  Tracker lied_to(TrackerOptions{});
  for (vo_delta_t m : stream) {
    if (m.utime == 6 * 50'000) continue;
    if (m.utime == 7 * 50'000) m.odom_translation[0] += 100.0;
    ASSERT_TRUE(lied_to.addVo(m));
    if (m.utime == 7 * 50'000) break;
  }
  EXPECT_EQ(lied_to.counts().reanchored, 1);
  EXPECT_EQ(lied_to.counts().odometry_bridged, 0);
}

TEST(Tracker, ASilenceTheWheelsCarriedIsReplacedByVosOdometryPosesWhenVoIsBack) {
  // The link to the base station drops for 1.6 s in a turn. A wheel message is the first to
  // arrive after it: VO timed out and the wheels, whose yaw reads 10 % short, carried the
  // hole. VO's next frame rides on a keyframe the tracker never saw; its odometry pose and the
  // last frame's span the silence, and VO's motion replaces the wheels': Δ is as if nothing
  // had been lost. Without the poses the wheels' 6 degrees stay.
  const std::vector<vo_delta_t> stream = turnStream(60, 1e-6);
  std::vector<wheel_odom_t> wheels;
  messages::WheelOdometryFrame wheel_frame;
  const SE3d step = planar(0.05, 0.0, 2.0 * std::numbers::pi / 180.0);
  for (int k = 1; k <= 30; ++k) {  // 10 Hz
    const auto m = core::toPlanar(step * step);
    wheel_odom_t w = wheelMsg((k - 1) * 100'000, k * 100'000, m.translation().x());
    w.delta_y_m = m.translation().y();
    w.delta_theta_rad = 0.9 * m.theta();
    wheel_frame.stamp(w);
    wheels.push_back(w);
  }
  const auto lost = [](int64_t utime, int64_t to) { return utime > 500'000 && utime <= to; };
  const auto run = [&](Tracker& t, const std::vector<vo_delta_t>& vo, bool lose, bool poses,
                       double lie_m) {
    std::size_t next_wheel = 0;
    for (vo_delta_t m : vo) {
      for (; next_wheel < wheels.size() && wheels[next_wheel].utime <= m.utime; ++next_wheel) {
        if (!lose || !lost(wheels[next_wheel].utime, 2'000'000)) {
          ASSERT_TRUE(t.addWheel(wheels[next_wheel]));
        }
      }
      if (lose && lost(m.utime, 2'100'000)) continue;
      if (!poses) m.odom_epoch = 0;
      if (m.utime == 2'150'000) m.odom_translation[0] += lie_m;
      ASSERT_TRUE(t.addVo(m));
    }
  };
  Tracker all(TrackerOptions{}), bridged(TrackerOptions{}), unbridged(TrackerOptions{});
  ASSERT_NO_FATAL_FAILURE(run(all, stream, false, true, 0.0));
  ASSERT_NO_FATAL_FAILURE(run(bridged, stream, true, true, 0.0));
  ASSERT_NO_FATAL_FAILURE(run(unbridged, stream, true, false, 0.0));
  EXPECT_EQ(bridged.counts().vo_timeouts, 1);
  EXPECT_EQ(bridged.counts().odometry_bridged, 1);
  EXPECT_EQ(unbridged.counts().odometry_bridged, 0);
  const auto yaw_error = [&](const Tracker& t) {
    return std::abs(core::toPlanar(t.delta().mean.inverse() * all.delta().mean).theta());
  };
  EXPECT_LT((bridged.delta().mean.inverse() * all.delta().mean).log().norm(), 1e-9);
  EXPECT_GT(yaw_error(unbridged), 5.0 * std::numbers::pi / 180.0);
  // A pose that lies (3 m in the turn, within what a robot drives in 1.65 s) contradicts
  // the wheels: they keep the gap.
  Tracker lied_to(TrackerOptions{});
  ASSERT_NO_FATAL_FAILURE(run(lied_to, stream, true, true, 3.0));
  EXPECT_EQ(lied_to.counts().odometry_bridged, 0);
  EXPECT_EQ(lied_to.counts().relinks_refused, 1);
  EXPECT_NEAR(yaw_error(lied_to), yaw_error(unbridged), 1e-9);
  // VO's motion over the silence less certain than the wheels' (its chain bridged a break by
  // its motion prior): the wheels keep the gap.
  Tracker weaker(TrackerOptions{});
  ASSERT_NO_FATAL_FAILURE(run(weaker, turnStream(60, 1e-1), true, true, 0.0));
  EXPECT_EQ(weaker.counts().odometry_bridged, 0);
  EXPECT_EQ(weaker.counts().relinks_weaker, 1);
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
  for (int k = 2; k <= 10; ++k)
    ASSERT_TRUE(t.addWheel(wheelMsg((k - 1) * 100000, k * 100000, 0.1)));
  EXPECT_FALSE(t.voTracking());
  EXPECT_EQ(t.counts().vo_timeouts, 1);
  EXPECT_NEAR(t.delta().mean.translation().x(), 0.1 + 0.9, 1e-12);
  ASSERT_TRUE(t.addVo(voRestart(1000000)));
  ASSERT_TRUE(t.addVo(voMsg(1100000, 1000000, planar(0.1, 0, 0), 1e-3, false)));
  EXPECT_NEAR(t.delta().mean.translation().x(), 1.1, 1e-12);
}

TEST(Tracker, WheelMessagesLostInAPartitionAreBridgedByTheirOdometryPoses) {
  // The link to the base station is down for 5 s: neither VO_DELTA nor WHEEL_ODOM reach the
  // mapper. The first wheel message after it spans the hole by its odometry pose (the robot's
  // integration went on), so the body is where the wheels say, not where the link broke.
  TrackerOptions o;
  o.vo_timeout_s = 0.5;
  Tracker t(o);
  const int64_t t0 = 1'000'000;
  messages::WheelOdometryFrame frame;
  ASSERT_TRUE(t.addVo(voRestart(t0)));
  ASSERT_TRUE(t.addVo(voMsg(t0 + 100000, t0, planar(0.1, 0, 0), 1e-3, false)));
  for (int k = 1; k <= 60; ++k) {  // 0.1 m every 0.1 s
    wheel_odom_t w = wheelMsg(t0 + (k - 1) * 100000, t0 + k * 100000, 0.1);
    frame.stamp(w);
    if (k >= 2 && k <= 50) continue;  // lost: 0.1 s to 5.0 s
    ASSERT_TRUE(t.addWheel(w));
  }
  EXPECT_EQ(t.counts().vo_timeouts, 1);
  EXPECT_NEAR(t.delta().mean.translation().x(), 0.1 + 5.0 + 0.9, 1e-9);
  EXPECT_EQ(t.counts().dropped, 0);
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

}  // namespace
}  // namespace evermap::mapper
