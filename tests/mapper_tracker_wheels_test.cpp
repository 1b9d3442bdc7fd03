// mapper-proc: the wheels' translation fused into VO's keyframe steps
// (TrackerOptions::wheel_translation; docs/contracts.md).

#include <gtest/gtest.h>

#include <cstdint>
#include <numbers>

#include "mapper-proc/tracker.h"
#include "tests/mapper_messages.h"

namespace evermap::mapper {
namespace {

using namespace testing;  // tests/mapper_messages.h

constexpr int64_t kStart = 1'000'000;  // VO's reference keyframe; the step ends 1 s later

struct Step {
  double vo_x = 0.4;             // VO's forward motion over the step
  double vo_yaw = 0.0;           // ... and its turn
  double vo_sigma = 0.002;       // per axis
  double wheel_scale = 1.0;      // the wheels carry the body 0.4 m x this
  double wheel_variance = 4e-7;  // of each 10 Hz increment
  int lost_wheel = -1;           // a wheel message lost (not bridged)
};

// One keyframe step [kStart, kStart + 1 s] of VO (frames every 0.1 s, the last one the
// keyframe) beside wheel increments of 0.1 s half a period off VO's frames: the step's first
// and last half periods are shares of an increment, the last one extrapolated at the wheels'
// last rate (its message comes after the step).
Tracker stepBesideWheels(const TrackerOptions& o, const Step& s) {
  Tracker t(o);
  EXPECT_TRUE(t.addVo(voRestart(kStart)));
  const double d = 0.04 * s.wheel_scale;
  auto wheel = [&](int i) {  // [kStart - 0.05 s + (i - 1) 0.1 s, + 0.1 s]
    if (i == s.lost_wheel) return;
    const int64_t end = kStart - 50000 + i * 100000;
    EXPECT_TRUE(t.addWheel(wheelMsg(end - 100000, end, d, s.wheel_variance)));
  };
  wheel(0);
  wheel(1);
  for (int k = 1; k <= 10; ++k) {
    const double f = k / 10.0;
    EXPECT_TRUE(t.addVo(voMsg(kStart + k * 100000, kStart, planar(s.vo_x * f, 0, s.vo_yaw * f),
                              s.vo_sigma, k == 10)));
    if (k < 10) wheel(k + 1);
  }
  return t;
}

TEST(TrackerWheels, TheWheelsCarryAStepWhoseScaleVoCouldNotMeasure) {
  // A near-blank corridor, every feature far ahead: VO has 0.2 m of a 0.4 m step, and its
  // covariance (2 cm) grew, though not to its error. The wheels' translation (increments of
  // 1 mm) is fused in by the two covariances and carries the step.
  const Step corridor{.vo_x = 0.2, .vo_sigma = 0.02, .wheel_variance = 1e-6};
  Tracker t = stepBesideWheels(TrackerOptions{}, corridor);
  EXPECT_NEAR(t.delta().mean.translation().x(), 0.4, 0.01);
  EXPECT_NEAR(t.delta().mean.translation().y(), 0.0, 1e-9);
  EXPECT_LT(t.delta().covariance(0, 0), 2e-5);
  EXPECT_EQ(t.counts().wheel_fused, 1);
  EXPECT_EQ(t.counts().wheel_disagreed, 1);
  // Off: VO's translation alone.
  TrackerOptions off;
  off.wheel_translation = false;
  Tracker vo_only = stepBesideWheels(off, corridor);
  EXPECT_NEAR(vo_only.delta().mean.translation().x(), 0.2, 1e-12);
  EXPECT_EQ(vo_only.counts().wheel_fused, 0);
}

TEST(TrackerWheels, TheWheelsMeasureTheStepInItsReferencesFrameAlsoInATurn) {
  // The body turned 90° over the step: the wheels' translation is the reference's x, which is
  // the body's y at the keyframe. Taken in the body's frame, the correction would go sideways.
  Step turn{.vo_x = 0.2, .vo_yaw = std::numbers::pi / 2, .vo_sigma = 0.02, .wheel_variance = 1e-6};
  Tracker t = stepBesideWheels(TrackerOptions{}, turn);
  EXPECT_NEAR(t.delta().mean.translation().x(), 0.4, 0.01);
  EXPECT_NEAR(t.delta().mean.translation().y(), 0.0, 0.002);
  EXPECT_EQ(t.counts().wheel_fused, 1);
}

TEST(TrackerWheels, AWheelSlipMovesAStepVoMeasuredWellByLittle) {
  // The wheels slip (20 % more than the body moved), which their covariance does not know;
  // VO measured the step to 0.6 mm. The step moves toward the wheels by under 2 mm.
  Tracker t = stepBesideWheels(
      TrackerOptions{}, Step{.vo_sigma = 0.0006, .wheel_scale = 1.2, .wheel_variance = 1.6e-6});
  EXPECT_GT(t.delta().mean.translation().x(), 0.4 + 1e-4);
  EXPECT_LT(t.delta().mean.translation().x(), 0.402);
  EXPECT_EQ(t.counts().wheel_disagreed, 1);
  // Agreeing sensors: fused, not counted as disagreeing; the step is as certain as the two
  // together.
  Tracker agree = stepBesideWheels(TrackerOptions{}, Step{});
  EXPECT_NEAR(agree.delta().mean.translation().x(), 0.4, 1e-9);
  EXPECT_EQ(agree.counts().wheel_fused, 1);
  EXPECT_EQ(agree.counts().wheel_disagreed, 0);
  EXPECT_LT(agree.delta().covariance(0, 0), 0.002 * 0.002 * 0.6);
}

TEST(TrackerWheels, AHoleInTheWheelsLeavesTheStepToVo) {
  // A wheel message lost inside the step, with no odometry pose to bridge it: the wheels'
  // motion over the step is not known, and VO's step is kept as it is.
  Tracker t =
      stepBesideWheels(TrackerOptions{}, Step{.vo_x = 0.2, .vo_sigma = 0.02, .lost_wheel = 5});
  EXPECT_NEAR(t.delta().mean.translation().x(), 0.2, 1e-12);
  EXPECT_EQ(t.counts().wheel_fused, 0);
}

TEST(TrackerWheels, AVoRestartOlderThanTheWheelsTakesTheirIncrementsAfterItBack) {
  // vo-proc holds its first seconds (vo_pipeline.h): the wheels carry the body 3 m at 1 m/s
  // before VO's first frame, stamped 1 s, arrives; VO's frames then cover 1-3 s again. Counted
  // twice, Δ would say 5 m.
  Tracker t{TrackerOptions{}};
  constexpr int64_t kT0 = 10'000'000;
  for (int i = 1; i <= 30; ++i)
    ASSERT_TRUE(t.addWheel(wheelMsg(kT0 + (i - 1) * 100000, kT0 + i * 100000, 0.1, 1e-6)));
  EXPECT_NEAR(t.delta().mean.translation().x(), 3.0, 1e-9);
  const int64_t ref = kT0 + 1'000'000;
  ASSERT_TRUE(t.addVo(voRestart(ref)));
  EXPECT_NEAR(t.delta().mean.translation().x(), 1.0, 1e-9);
  EXPECT_EQ(t.counts().wheels_taken_back, 20);
  for (int k = 1; k <= 20; ++k)
    ASSERT_TRUE(t.addVo(voMsg(ref + k * 100000, ref, planar(0.1 * k, 0, 0), 0.002, k == 20)));
  EXPECT_NEAR(t.delta().mean.translation().x(), 3.0, 1e-6);
  // VO's first frame in time (no hold): nothing to take back.
  Tracker on_time{TrackerOptions{}};
  for (int i = 1; i <= 10; ++i)
    ASSERT_TRUE(on_time.addWheel(wheelMsg(kT0 + (i - 1) * 100000, kT0 + i * 100000, 0.1, 1e-6)));
  ASSERT_TRUE(on_time.addVo(voRestart(ref)));
  EXPECT_NEAR(on_time.delta().mean.translation().x(), 1.0, 1e-9);
  EXPECT_EQ(on_time.counts().wheels_taken_back, 0);
}

}  // namespace
}  // namespace evermap::mapper
