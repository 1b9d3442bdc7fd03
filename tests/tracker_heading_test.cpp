// evermap::mapper::Tracker with the gyro's heading (ATTITUDE heading_rad): wheel increments'
// yaw fused with the gyro's while VO is down.

#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "core/geometry/se2.h"
#include "mapper-proc/mapper.h"
#include "mapper-proc/tracker.h"
#include "tests/mapper_messages.h"

namespace evermap::mapper {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;
using testing::heading;

wheel_odom_t wheel(int64_t prev, int64_t utime, double dx, double dtheta, double theta_var) {
  wheel_odom_t w{};
  w.prev_utime = prev;
  w.utime = utime;
  w.delta_x_m = dx;
  w.delta_theta_rad = dtheta;
  w.covariance[0] = w.covariance[4] = 1e-4;
  w.covariance[8] = theta_var;
  return w;
}

double yawOf(const Tracker& t) { return core::toPlanar(t.delta().mean).theta(); }

// Wheels with no VO at all: the robot turns 90 degrees in place over 2 s, the wheels say 80.
// ATTITUDE at 50 Hz carries the true turn.
void turnInPlace(Tracker* t, bool with_gyro) {
  const double true_rate = (std::numbers::pi / 2) / 2.0;  // rad/s
  int64_t att = 0;
  for (int k = 1; k <= 20; ++k) {
    const int64_t t0 = (k - 1) * 100000, t1 = k * 100000;
    for (; with_gyro && att <= t1; att += 20000)
      ASSERT_TRUE(t->addHeading(heading(att, true_rate * att * 1e-6)));
    ASSERT_TRUE(t->addWheel(
        wheel(t0, t1, 0.0, 0.8 * true_rate * 0.1, std::pow(0.02 * true_rate * 0.1, 2))));
  }
}

TEST(TrackerHeading, TheGyroTurnsTheBodyWhereTheWheelsSlip) {
  Tracker with(TrackerOptions{}), without(TrackerOptions{});
  turnInPlace(&with, true);
  turnInPlace(&without, false);
  EXPECT_NEAR(yawOf(without), 0.8 * std::numbers::pi / 2, 1e-9);
  // Information-weighted per increment: the wheels' σθ = 0.02 x 0.0785 rad against the gyro's
  // σ² = (1e-4)² x 0.1 x 10 + (1e-3)² x 0.1: 96 % of the weight on the gyro; 18 degrees of
  // wheel error become 0.75.
  const double wheel_var = std::pow(0.02 * (std::numbers::pi / 4) * 0.1, 2),
               gyro_var = 1e-8 * 0.1 * 10 + 1e-6 * 0.1;
  const double w = wheel_var / (wheel_var + gyro_var);
  EXPECT_NEAR(yawOf(with), std::numbers::pi / 2 * (0.8 + 0.2 * w), 1e-6);
  EXPECT_NEAR(yawOf(with), std::numbers::pi / 2, 1.0 * kDeg);
  EXPECT_EQ(with.counts().gyro_turns, 20);
  EXPECT_EQ(without.counts().gyro_turns, 0);
  // The fused yaw is more certain than the wheels' alone.
  EXPECT_LT(with.delta().covariance(5, 5), without.delta().covariance(5, 5));
}

TEST(TrackerHeading, AnUncertainGyroBiasLeavesTheWheelsTheirWeight) {
  // Before any still window the gyro's bias is known to 0.02 rad/s: over 0.1 s increments
  // that is σ² = 0.02² x 0.1 x 10 = 4e-4 rad² each, against the wheels' 1e-6: the wheels win.
  Tracker t(TrackerOptions{});
  int64_t att = 0;
  for (int k = 1; k <= 10; ++k) {
    for (; att <= k * 100000; att += 20000)
      ASSERT_TRUE(t.addHeading(heading(att, 0.5 * att * 1e-6, 0.02)));
    ASSERT_TRUE(t.addWheel(wheel((k - 1) * 100000, k * 100000, 0.1, 0.0, 1e-6)));
  }
  EXPECT_LT(std::abs(yawOf(t)), 0.02);  // the gyro says 0.5 rad
  EXPECT_EQ(t.counts().gyro_turns, 10);
}

TEST(TrackerHeading, HeadingsThatDoNotCoverAnIncrementAreNotUsed) {
  Tracker t(TrackerOptions{});
  // Headings stop at 0.2 s; an increment ending at 1.0 s is beyond the extrapolation.
  for (int64_t a = 0; a <= 200000; a += 20000)
    ASSERT_TRUE(t.addHeading(heading(a, 1.0 * a * 1e-6)));
  ASSERT_TRUE(t.addWheel(wheel(900000, 1000000, 0.1, 0.01, 1e-4)));
  EXPECT_EQ(t.counts().gyro_turns, 0);
  EXPECT_NEAR(yawOf(t), 0.01, 1e-12);
}

TEST(TrackerHeading, AnExtrapolatedHeadingDoesNotUndoATurnThatStartedAfterIt) {
  // The body stood still until 1.0 s, the newest ATTITUDE; it turns in the next 0.1 s, and
  // the wheel increment saying so comes before the ATTITUDE that would. Extrapolated at its
  // last rate the gyro says no turn; counted as measured (σ² ~1e-7 rad² against the
  // wheels' 2.6e-6) it would erase 96 % of the turn. The extrapolated 0.1 s is good only to
  // the turn rate's change over it (1 rad/s x 0.1 s): the wheels keep the turn.
  Tracker t(TrackerOptions{});
  for (int64_t a = 0; a <= 1000000; a += 20000) ASSERT_TRUE(t.addHeading(heading(a, 0.0)));
  ASSERT_TRUE(t.addWheel(wheel(1000000, 1100000, 0.0, 0.08, std::pow(0.02 * 0.08, 2))));
  EXPECT_EQ(t.counts().gyro_turns, 1);
  EXPECT_NEAR(yawOf(t), 0.08, 0.002);
  // Covered by a heading, the same disagreement goes the gyro's way.
  Tracker covered(TrackerOptions{});
  for (int64_t a = 0; a <= 1100000; a += 20000) ASSERT_TRUE(covered.addHeading(heading(a, 0.0)));
  ASSERT_TRUE(covered.addWheel(wheel(1000000, 1100000, 0.0, 0.08, std::pow(0.02 * 0.08, 2))));
  EXPECT_LT(std::abs(yawOf(covered)), 0.01);
}

TEST(TrackerHeading, ARestartedImuProcBreaksTheHeadingInsteadOfJumping) {
  // imu-proc restarted: its heading starts again from 0 after a gap. No increment spanning
  // the restart may take the jump as a turn.
  Tracker t(TrackerOptions{});
  for (int64_t a = 0; a <= 1000000; a += 20000) ASSERT_TRUE(t.addHeading(heading(a, 2.0)));
  for (int64_t a = 1600000; a <= 2200000; a += 20000) ASSERT_TRUE(t.addHeading(heading(a, 0.0)));
  ASSERT_TRUE(t.addWheel(wheel(900000, 1700000, 0.1, 0.0, 1e-4)));
  EXPECT_NEAR(yawOf(t), 0.0, 1e-12);
  EXPECT_EQ(t.counts().gyro_turns, 0);
  // After the restart the new headings are used.
  ASSERT_TRUE(t.addWheel(wheel(1800000, 1900000, 0.1, 0.0, 1e-4)));
  EXPECT_EQ(t.counts().gyro_turns, 1);
}

TEST(TrackerHeading, HeadingsLostOnALinkAreBridgedWhenTheySayTheyAreOneIntegration) {
  // A partition drops ATTITUDE from 1.0 s to 2.6 s; the robot starts turning at 0.5 rad/s
  // at 1.5 s, unseen. The wheels (yaw 20 % short) carry 1.05 s to 2.7 s. Headings of one
  // epoch span the gap: the increment gets the gyro's 0.6 rad, its start (inside the gap)
  // extrapolated from before it, not interpolated across it into the turn. Headings without
  // an epoch (an older imu-proc), or of two epochs (a restart), bridge nothing.
  const auto truth = [](int64_t t) { return t < 1'500'000 ? 0.0 : 0.5 * (t - 1'500'000) * 1e-6; };
  const auto run = [&](Tracker& t, int64_t epoch_before, int64_t epoch_after) {
    for (int64_t a = 0; a <= 3'000'000; a += 20'000) {
      if (a > 1'000'000 && a < 2'600'000) continue;
      ASSERT_TRUE(
          t.addHeading(heading(a, truth(a), 1e-4, a <= 1'000'000 ? epoch_before : epoch_after)));
    }
    ASSERT_TRUE(t.addWheel(wheel(0, 1'050'000, 0.0, 0.0, 1e-4)));
    ASSERT_TRUE(t.addWheel(wheel(1'050'000, 2'700'000, 0.0, 0.8 * 0.6, 1e-2)));
  };
  Tracker one(TrackerOptions{}), old(TrackerOptions{}), restarted(TrackerOptions{});
  ASSERT_NO_FATAL_FAILURE(run(one, 7, 7));
  ASSERT_NO_FATAL_FAILURE(run(old, 0, 0));
  ASSERT_NO_FATAL_FAILURE(run(restarted, 7, 2'600'000));
  EXPECT_NEAR(yawOf(one), 0.6, 2e-3);
  EXPECT_EQ(one.counts().gyro_turns, 2);
  EXPECT_NEAR(yawOf(old), 0.48, 1e-9);
  EXPECT_NEAR(yawOf(restarted), 0.48, 1e-9);
}

TEST(TrackerHeading, MalformedHeadingsAreDroppedAndCounted) {
  Tracker t(TrackerOptions{});
  attitude_t bad = heading(0, std::nan(""));
  EXPECT_FALSE(t.addHeading(bad));
  ASSERT_TRUE(t.addHeading(heading(20000, 0.0)));
  EXPECT_FALSE(t.addHeading(heading(10000, 0.0)));  // out of order
  attitude_t none = heading(30000, 5.0);
  none.heading_valid = 0;
  EXPECT_TRUE(t.addHeading(none));  // no heading in it: nothing to use, nothing wrong
  EXPECT_EQ(t.counts().dropped, 2);
}

TEST(TrackerHeading, AVoRestartBetweenWheelMessagesIsPlacedWhereTheBodyIsThen) {
  // Turning in place at 0.8 rad/s on wheels; VO restarts 50 ms after the last wheel message.
  // The reference goes where the body is at the restart: the gyro's yaw over those 50 ms.
  Tracker t(TrackerOptions{});
  const double rate = 0.8;
  for (int64_t a = 0; a <= 600000; a += 20000)
    ASSERT_TRUE(t.addHeading(heading(a, rate * a * 1e-6)));
  for (int k = 1; k <= 5; ++k)
    ASSERT_TRUE(t.addWheel(wheel((k - 1) * 100000, k * 100000, 0.0, rate * 0.1, 1e-4)));
  vo_delta_t restart{};
  restart.utime = 550000;
  restart.ref_utime = 550000;
  restart.status = vo_delta_t::STATUS_NO_DATA;
  restart.keyframe_changed = 1;
  ASSERT_TRUE(t.addVo(restart));
  EXPECT_NEAR(yawOf(t), rate * 0.55, 1e-3);
}

TEST(TrackerHeading, AWheelIncrementThatStartsBeforeVoWasLostCountsOnlyItsShareAfter) {
  // VO's last good frame at 150 ms; the wheel increment [100, 200] ms is half VO's already.
  Tracker t(TrackerOptions{});
  vo_delta_t first{};
  first.utime = first.ref_utime = 0;
  first.status = vo_delta_t::STATUS_NO_DATA;
  first.keyframe_changed = 1;
  ASSERT_TRUE(t.addVo(first));
  vo_delta_t good{};
  good.utime = 150000;
  good.ref_utime = 0;
  good.status = vo_delta_t::STATUS_OK;
  good.translation[0] = 0.15;
  good.orientation[0] = 1.0;
  for (int i = 0; i < 6; ++i) good.covariance[7 * i] = 1e-6;
  ASSERT_TRUE(t.addVo(good));
  ASSERT_TRUE(t.addWheel(wheel(100000, 200000, 0.1, 0.0, 1e-4)));
  vo_delta_t fail = good;
  fail.utime = 200000;
  fail.status = vo_delta_t::STATUS_INSUFFICIENT_FEATURES;
  ASSERT_TRUE(t.addVo(fail));
  // 0.15 by VO, then the wheels' 0.05 after 150 ms (the camera sits on the body's axis here).
  EXPECT_NEAR(t.delta().mean.translation().x(), 0.2, 1e-9);
}

// Straight at 1 m/s for 3 s: ATTITUDE at 50 Hz (no turn), exact wheels at 10 Hz, VO at 10 Hz
// with a keyframe every third frame, σ 1 mm / 1 mrad. Over the keyframe step [1.2, 1.5] s
// VO claims a 10° turn and three times the distance (moving texture, a wrong match) with
// the same confidence. `wheels`: whether WHEEL_ODOM is sent; `wheels_until_s`: when the
// wheel driver stops; `glitch_steps`: how many keyframe steps from 1.2 s on glitch alike.
Tracker driveWithAVoGlitch(double vo_gyro_gate, bool wheels, double wheels_until_s = 10.0,
                           int glitch_steps = 1) {
  TrackerOptions o;
  o.vo_gyro_gate = vo_gyro_gate;
  Tracker t(o);
  int64_t att = 0;
  EXPECT_TRUE(t.addVo(testing::voRestart(0)));
  int64_t ref = 0;
  for (int k = 1; k <= 30; ++k) {
    const int64_t t1 = k * 100000;
    for (; att <= t1; att += 20000) EXPECT_TRUE(t.addHeading(heading(att, 0.0)));
    if (wheels && t1 <= wheels_until_s * 1e6) {
      EXPECT_TRUE(t.addWheel(wheel(t1 - 100000, t1, 0.1, 0.0, 1e-6)));
    }
    const double since_ref = 1e-6 * static_cast<double>(t1 - ref);
    const bool glitch = ref >= 1200000 && ref < 1200000 + glitch_steps * 300000;
    const SE3d ref_T_cur =
        glitch ? testing::planar(3.0 * since_ref, 0.0, 10.0 * kDeg * since_ref / 0.3)
               : testing::planar(since_ref, 0.0, 0.0);
    const bool keyframe = k % 3 == 0;
    EXPECT_TRUE(t.addVo(testing::voMsg(t1, ref, ref_T_cur, 1e-3, keyframe)));
    if (keyframe) ref = t1;
  }
  return t;
}

TEST(TrackerHeading, AVoStepTheGyroContradictsIsCarriedByTheWheels) {
  const Tracker gated = driveWithAVoGlitch(16.0, true);
  EXPECT_EQ(gated.counts().vo_contradicted, 1);
  EXPECT_EQ(gated.counts().heading_waits, 0);  // each heading came before the frame it reaches
  // The wheels carried the step, VO the rest: the body is where it drove.
  EXPECT_NEAR(gated.delta().mean.translation().x(), 3.0, 1e-6);
  EXPECT_NEAR(gated.delta().mean.translation().y(), 0.0, 1e-6);
  EXPECT_NEAR(yawOf(gated), 0.0, 1e-6);
  // Without the test the gyro's fusion takes part of the turn back, not the distance.
  const Tracker fused = driveWithAVoGlitch(0.0, true);
  EXPECT_EQ(fused.counts().vo_contradicted, 0);
  EXPECT_GT(std::abs(yawOf(fused)), 1.0 * kDeg);
  EXPECT_GT(fused.delta().mean.translation().x(), 3.5);
  // Without wheels there is nothing to carry the step: VO's motion stays, its yaw fused.
  const Tracker no_wheels = driveWithAVoGlitch(16.0, false);
  EXPECT_EQ(no_wheels.counts().vo_contradicted, 0);
  EXPECT_NEAR(yawOf(no_wheels), yawOf(fused), 1e-9);
  // Wheels that stopped at 1.0 s cannot carry the step (their last increments are still
  // kept): VO's motion stays, its yaw fused, as without the test; no motion is lost.
  const Tracker stopped = driveWithAVoGlitch(16.0, true, 1.0);
  const Tracker stopped_fused = driveWithAVoGlitch(0.0, true, 1.0);
  EXPECT_EQ(stopped.counts().vo_contradicted, 0);
  EXPECT_NEAR(stopped.delta().mean.translation().x(), stopped_fused.delta().mean.translation().x(),
              1e-9);
  EXPECT_GT(stopped.delta().mean.translation().x(), 3.5);
  TrackerOptions bad;
  bad.vo_gyro_gate = -1.0;
  EXPECT_FALSE(bad.validate());
}

// A passer-by filling the view for a second: VO's next step, whose reference the wheels
// placed (reanchored) after the first contradiction, is wrong alike. The gyro tests it too,
// and the wheels carry Δ from the frame that placed its reference (rendered seed 4, 160-161 s:
// 3.6° of heading otherwise kept).
TEST(TrackerHeading, AStepFromAReanchoredReferenceTheGyroContradictsIsCarriedByTheWheels) {
  const Tracker twice = driveWithAVoGlitch(16.0, true, 10.0, 2);
  EXPECT_EQ(twice.counts().vo_contradicted, 2);
  EXPECT_EQ(twice.counts().reanchored, 2);
  EXPECT_NEAR(twice.delta().mean.translation().x(), 3.0, 1e-6);
  EXPECT_NEAR(twice.delta().mean.translation().y(), 0.0, 1e-6);
  EXPECT_NEAR(yawOf(twice), 0.0, 1e-6);
  // A right step from a reanchored reference passes the test and is kept (the first glitch
  // only): the body ends where it drove.
  const Tracker once = driveWithAVoGlitch(16.0, true);
  EXPECT_EQ(once.counts().vo_contradicted, 1);
  EXPECT_EQ(once.counts().reanchored, 1);
  EXPECT_NEAR(once.delta().mean.translation().x(), 3.0, 1e-6);
  EXPECT_NEAR(yawOf(once), 0.0, 1e-6);
  // Without wheels nothing carries either step: VO's motion stays.
  const Tracker no_wheels = driveWithAVoGlitch(16.0, false, 10.0, 2);
  EXPECT_EQ(no_wheels.counts().vo_contradicted, 0);
  EXPECT_GT(no_wheels.delta().mean.translation().x(), 3.5);
}

// Straight at 1 m/s, wheels every 0.2 s ending at odd tenths, VO every 0.1 s. VO's keyframe
// step to 0.9 s claims a turn the gyro contradicts; VO's frame at 1.0 s refers to that
// keyframe, which the tracker did not take (reanchored there), and its step to 1.1 s claims a
// turn too. `vo_late`: VO's messages for 1.0 and 1.1 s come after the wheels' increment to
// 1.1 s (live, VO lags), else before it.
Tracker reanchoredGlitch(bool vo_late) {
  TrackerOptions o;
  o.vo_gyro_gate = 16.0;
  Tracker t(o);
  for (int64_t att = 0; att <= 1500000; att += 20000) EXPECT_TRUE(t.addHeading(heading(att, 0.0)));
  auto wheelTo = [&](int64_t t1) {
    EXPECT_TRUE(t.addWheel(wheel(t1 - 200000, t1, 0.2, 0.0, 1e-6)));
  };
  auto vo = [&](int64_t utime, int64_t ref, double turn_deg, bool keyframe) {
    const double d = 1e-6 * static_cast<double>(utime - ref);
    EXPECT_TRUE(t.addVo(
        testing::voMsg(utime, ref, testing::planar(d, 0.0, turn_deg * kDeg), 1e-3, keyframe)));
  };
  EXPECT_TRUE(t.addVo(testing::voRestart(0)));
  EXPECT_TRUE(t.addWheel(wheel(0, 100000, 0.1, 0.0, 1e-6)));
  for (int k = 1; k <= 6; ++k) {
    if (k % 2 == 1 && k > 1) wheelTo(k * 100000);
    vo(k * 100000, k <= 3 ? 0 : 300000, 0.0, k % 3 == 0);
  }
  wheelTo(700000);
  vo(700000, 600000, 0.0, false);
  vo(800000, 600000, 5.0, false);
  wheelTo(900000);
  vo(900000, 600000, 10.0, true);  // contradicted: the wheels carry Δ from 0.6 s
  if (vo_late) wheelTo(1100000);
  vo(1000000, 900000, 0.0, false);  // a reference the tracker did not take: reanchored here
  vo(1100000, 900000, 8.0, true);   // contradicted too
  if (!vo_late) wheelTo(1100000);
  return t;
}

// The step from a reanchored reference ends before the wheels' next increment (VO makes a
// keyframe of every frame while few points match, and its message comes first): the wheels'
// last increment before the reanchoring is kept, so they carry it all the same (rendered seed
// 4, 237.5 s: 2.9° of heading otherwise kept). Live, VO's messages come after the wheels':
// the wheels take over from where Δ had the body, not from the frame, so no increment counts
// twice.
TEST(TrackerHeading,
     TheWheelsCarryAContradictedStepFromAReanchoredReferenceBeforeTheirNextIncrement) {
  for (const bool vo_late : {false, true}) {
    SCOPED_TRACE(vo_late ? "VO late" : "VO first");
    const Tracker t = reanchoredGlitch(vo_late);
    EXPECT_EQ(t.counts().vo_contradicted, 2);
    EXPECT_EQ(t.counts().reanchored, 1);
    EXPECT_NEAR(yawOf(t), 0.0, 1e-6);
    EXPECT_NEAR(t.delta().mean.translation().x(), 1.1, 1e-6);
    EXPECT_NEAR(t.delta().mean.translation().y(), 0.0, 1e-6);
  }
}

TEST(TrackerHeading, AVoStepThatTurnsWithTheGyroIsKept) {
  // Turning in place at 0.5 rad/s for 1.5 s, VO and the gyro agreeing; the wheels say half
  // the turn (slip). No step is contradicted and VO's turn stands.
  TrackerOptions o;
  o.vo_gyro_gate = 16.0;
  Tracker t(o);
  ASSERT_TRUE(t.addVo(testing::voRestart(0)));
  int64_t att = 0, ref = 0;
  for (int k = 1; k <= 15; ++k) {
    const int64_t t1 = k * 100000;
    for (; att <= t1; att += 20000) ASSERT_TRUE(t.addHeading(heading(att, 0.5 * att * 1e-6)));
    ASSERT_TRUE(t.addWheel(wheel(t1 - 100000, t1, 0.0, 0.025, 1e-6)));
    const bool keyframe = k % 3 == 0;
    ASSERT_TRUE(t.addVo(testing::voMsg(
        t1, ref, testing::planar(0, 0, 0.5e-6 * static_cast<double>(t1 - ref)), 1e-3, keyframe)));
    if (keyframe) ref = t1;
  }
  EXPECT_EQ(t.counts().vo_contradicted, 0);
  EXPECT_NEAR(yawOf(t), 0.75, 1e-3);
}

// Straight at 1 m/s for 3 s with exact wheels at 10 Hz and VO at 10 Hz (a keyframe every third
// frame, σ 1 mm / 1 mrad); over the keyframe step [1.2, 1.5] s VO turns 1° it did not
// (featureless texture, seed 3 of the rendered sessions). ATTITUDE at 50 Hz lags the frames by
// `lag_us` and each arrives after the VO frame it would cover, as imu-proc's do; with
// `headings_stop_s` the gyro falls silent then.
Tracker driveWithLaggingHeadings(double heading_wait_s, int64_t lag_us,
                                 double headings_stop_s = 10.0) {
  TrackerOptions o;
  o.heading_wait_s = heading_wait_s;
  Tracker t(o);
  EXPECT_TRUE(t.addVo(testing::voRestart(0)));
  int64_t att = 0, ref = 0;
  for (int k = 1; k <= 30; ++k) {
    const int64_t t1 = k * 100000;
    EXPECT_TRUE(t.addWheel(wheel(t1 - 100000, t1, 0.1, 0.0, 1e-6)));
    const double since_ref = 1e-6 * static_cast<double>(t1 - ref);
    const double yaw = ref == 1200000 ? 1.0 * kDeg * since_ref / 0.3 : 0.0;
    const bool keyframe = k % 3 == 0;
    EXPECT_TRUE(
        t.addVo(testing::voMsg(t1, ref, testing::planar(since_ref, 0.0, yaw), 1e-3, keyframe)));
    if (keyframe) ref = t1;
    for (; att <= t1 + 20000 - lag_us && att <= headings_stop_s * 1e6; att += 20000)
      EXPECT_TRUE(t.addHeading(heading(att, 0.0)));
  }
  return t;
}

TEST(TrackerHeading, AKeyframeStepWaitsForTheHeadingThatReachesIt) {
  // Taken at once, the step meets a heading 10 ms old, extrapolated: its variance
  // (1 rad/s x 10 ms)² = (0.57°)² leaves the gyro no say against VO's 0.06°, and the 1° stays.
  const Tracker at_once = driveWithLaggingHeadings(0.0, 10000);
  EXPECT_EQ(at_once.counts().heading_waits, 0);
  EXPECT_EQ(at_once.counts().vo_contradicted, 0);
  EXPECT_GT(std::abs(yawOf(at_once)), 0.8 * kDeg);
  // Held until the heading that reaches it: the gyro contradicts the step and the wheels carry
  // it. Each keyframe step waits, the one after the contradiction too (from a reference the
  // wheels placed: the gyro tests it as well).
  const Tracker waited = driveWithLaggingHeadings(0.1, 10000);
  EXPECT_EQ(waited.counts().heading_waits, 10);
  EXPECT_EQ(waited.counts().heading_waits_expired, 0);
  EXPECT_EQ(waited.counts().vo_contradicted, 1);
  EXPECT_NEAR(yawOf(waited), 0.0, 1e-6);
  EXPECT_NEAR(waited.delta().mean.translation().x(), 3.0, 1e-6);
  TrackerOptions bad;
  bad.heading_wait_s = -0.1;
  EXPECT_FALSE(bad.validate());
  bad.heading_wait_s = bad.vo_timeout_s;  // the wheels' takeover would find a step held
  EXPECT_FALSE(bad.validate());
}

TEST(TrackerHeading, StepsHeldWhenTheGyroFallsSilentAreTakenWithTheNextFrame) {
  // The headings stop at 1.0 s: the steps after wait in vain, each until the next VO frame,
  // and are then taken as they would have been at once; no motion is lost.
  const Tracker waited = driveWithLaggingHeadings(0.1, 10000, 1.0);
  const Tracker at_once = driveWithLaggingHeadings(0.0, 10000, 1.0);
  EXPECT_GT(waited.counts().heading_waits_expired, 0);
  EXPECT_EQ(waited.counts().heading_waits, waited.counts().heading_waits_expired + 3);
  EXPECT_LT((waited.delta().mean.translation() - at_once.delta().mean.translation()).norm(), 1e-9);
  EXPECT_NEAR(yawOf(waited), yawOf(at_once), 1e-9);
}

TEST(MapperHeading, TheStepAtAHeldKeyframeIsTakenWhenItsHeadingComes) {
  // The mapper's step (its registration request) at a keyframe the tracker holds comes with
  // the ATTITUDE that reaches it, not with the VO frame; with no wait, with the frame.
  for (const double wait_s : {0.1, 0.0}) {
    MapperOptions o;
    o.tracker.heading_wait_s = wait_s;
    Mapper m(o);
    floor_t f{};
    f.utime = 1;
    ASSERT_TRUE(m.onFloor(f));
    for (int64_t a = 0; a <= 990000; a += 20000) ASSERT_TRUE(m.onAttitude(heading(a, 0.0)));
    ASSERT_TRUE(m.onVo(testing::voRestart(1000000)));
    ASSERT_TRUE(m.onAttitude(heading(1010000, 0.0)));
    m.takeRequests();
    for (int64_t a = 1030000; a <= 1990000; a += 20000) ASSERT_TRUE(m.onAttitude(heading(a, 0.0)));
    ASSERT_TRUE(
        m.onVo(testing::voMsg(2000000, 1000000, testing::planar(1.0, 0.0, 0.0), 1e-3, true)));
    EXPECT_EQ(m.takeRequests().size(), wait_s > 0.0 ? 0u : 1u) << wait_s;
    EXPECT_EQ(m.tracker().heldKeyframeUtime(), wait_s > 0.0 ? 2000000 : -1);
    ASSERT_TRUE(m.onAttitude(heading(2010000, 0.0)));
    const auto requests = m.takeRequests();
    ASSERT_EQ(requests.size(), wait_s > 0.0 ? 1u : 0u) << wait_s;
    if (!requests.empty()) {
      EXPECT_EQ(requests.front().keyframe_utime, 2000000);
    }
    EXPECT_EQ(m.tracker().referenceUtime(), 2000000);
    EXPECT_EQ(m.stats().steps, 2);
  }
}

// A mapper on floor 0 with its first node at 1.0 s and headings up to 1.99 s; the keyframe at
// 2.0 s held for its heading.
struct HeldKeyframe {
  Mapper m{MapperOptions{}};
  HeldKeyframe() {
    floor_t f{};
    f.utime = 1;
    EXPECT_TRUE(m.onFloor(f));
    for (int64_t a = 0; a <= 990000; a += 20000) EXPECT_TRUE(m.onAttitude(heading(a, 0.0)));
    EXPECT_TRUE(m.onVo(testing::voRestart(1000000)));
    for (int64_t a = 1010000; a <= 1990000; a += 20000) EXPECT_TRUE(m.onAttitude(heading(a, 0.0)));
    m.takeRequests();
    EXPECT_TRUE(
        m.onVo(testing::voMsg(2000000, 1000000, testing::planar(1.0, 0.0, 0.0), 1e-3, true)));
    EXPECT_EQ(m.tracker().heldKeyframeUtime(), 2000000);
    EXPECT_TRUE(m.takeRequests().empty());
  }
};

TEST(MapperHeading, AHeldStepTheHeadingDoesNotReachIsTakenWithTheWheelsOnce) {
  // No ATTITUDE after the frame: the first wheel increment more than heading_wait_s past it
  // takes the step, and the mapper's with it.
  HeldKeyframe h;
  ASSERT_TRUE(h.m.onWheel(wheel(1900000, 2000000, 0.1, 0.0, 1e-6)));
  EXPECT_EQ(h.m.tracker().heldKeyframeUtime(), 2000000);
  ASSERT_TRUE(h.m.onWheel(wheel(2000000, 2150000, 0.15, 0.0, 1e-6)));
  EXPECT_EQ(h.m.tracker().heldKeyframeUtime(), -1);
  const auto requests = h.m.takeRequests();
  ASSERT_EQ(requests.size(), 1u);
  EXPECT_EQ(requests.front().keyframe_utime, 2000000);
  EXPECT_EQ(h.m.tracker().counts().heading_waits_expired, 1);
}

TEST(MapperHeading, AHeldStepIsNotTakenIntoTheNextSessionNorLate) {
  // The streams stop with the step held. A session's FLOOR (EVENT_NONE), or a heading that
  // comes 10 s later (beyond the request timeout), commits the step without the mapper's:
  // no registration of the old session's keyframe answers for the new one.
  {
    HeldKeyframe h;
    floor_t next{};
    next.utime = 700000000;
    next.event = floor_t::EVENT_NONE;
    ASSERT_TRUE(h.m.onFloor(next));
    EXPECT_EQ(h.m.tracker().heldKeyframeUtime(), -1);
    EXPECT_TRUE(h.m.takeRequests().empty());
    // A new session; its first one, which no registration confirmed, is quarantined
    // (mapper_lies_test) and the new one starts the map afresh, not lost.
    EXPECT_EQ(h.m.session(), 1);
    EXPECT_EQ(h.m.stats().sessions_quarantined, 1);
  }
  {
    HeldKeyframe h;
    ASSERT_TRUE(h.m.onAttitude(heading(12000000, 0.0)));
    EXPECT_EQ(h.m.tracker().heldKeyframeUtime(), -1);
    EXPECT_TRUE(h.m.takeRequests().empty());
    EXPECT_EQ(h.m.stats().steps, 1);
  }
}

}  // namespace
}  // namespace evermap::mapper
