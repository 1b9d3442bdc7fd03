// mapper-proc: the gyro's test of VO's steps (tracker.h, TrackerOptions::vo_gyro_gate) from
// a VO restart on, and of the motion before a failure, tested and fused as a step.

#include <gtest/gtest.h>

#include <cstdint>
#include <numbers>

#include "mapper-proc/tracker.h"
#include "tests/mapper_messages.h"

namespace evermap::mapper {
namespace {

using namespace testing;  // tests/mapper_messages.h

constexpr int64_t kStart = 1'000'000;  // VO's (re)start, the reference of every frame
constexpr double kDeg = std::numbers::pi / 180.0;

struct Drive {
  // VO's motion to frame k (0.1 s apart, k = 1..10) from the reference at kStart, as a share f
  // = k / 10 of the whole: forward 0.4 m f, turned by yaw f.
  double yaw = 0.0;
  double vo_sigma = 0.002;  // per axis, m and rad
  int fails_at = 0;         // frame k fails (0: none); the wheels carry on from there
  // The wheels' increments begin with the one straddling kStart (none ends before it), as
  // when the increments kept were cleared at VO's restart.
  bool wheels_from_restart = false;
};

// The body drives 0.4 m straight ahead in 1 s without turning; VO restarts at kStart
// and reports `d`; the last frame is a keyframe.
Tracker drive(const TrackerOptions& o, const Drive& d) {
  Tracker t(o);
  // The body does not turn: the gyro's heading at 50 Hz stays at 0.
  for (int64_t a = kStart - 200000; a <= kStart + 1500000; a += 20000)
    EXPECT_TRUE(t.addHeading(heading(a, 0.0)));
  EXPECT_TRUE(t.addVo(voRestart(kStart)));
  auto wheel = [&](int i) {  // [kStart - 0.05 s + (i - 1) 0.1 s, + 0.1 s]
    const int64_t end = kStart - 50000 + i * 100000;
    EXPECT_TRUE(t.addWheel(wheelMsg(end - 100000, end, 0.04, 4e-7)));
  };
  if (!d.wheels_from_restart) wheel(0);
  wheel(1);
  for (int k = 1; k <= 10; ++k) {
    const double f = k / 10.0;
    const SE3d motion(core::SO3d::exp(Vec3(0, 0, d.yaw * f)), Vec3(0.4 * f, 0, 0));
    vo_delta_t m = voMsg(kStart + k * 100000, kStart, motion, d.vo_sigma, k == 10);
    if (k >= d.fails_at && d.fails_at > 0) m.status = vo_delta_t::STATUS_INSUFFICIENT_INLIERS;
    EXPECT_TRUE(t.addVo(m));
    wheel(k + 1);
  }
  return t;
}

double yawOf(const Tracker& t) { return core::toPlanar(t.delta().mean).theta(); }

TEST(TrackerSteps, TheWheelsCarryAContradictedStepFromVosRestartOn) {
  // VO restarted at kStart, and the wheel increments kept begin with the one that straddles
  // it. VO's first step turns 10° the gyro does not: the wheels carry Δ over it from kStart
  // (their share of the straddling increment after kStart). Before, with no increment ending
  // before kStart the wheels did not count as covering the step, and VO's turn was kept.
  Tracker t = drive(TrackerOptions{}, Drive{.yaw = 10 * kDeg, .wheels_from_restart = true});
  EXPECT_EQ(t.counts().vo_contradicted, 1);
  EXPECT_NEAR(yawOf(t), 0.0, 0.1 * kDeg);
  EXPECT_NEAR(t.delta().mean.translation().x(), 0.42, 0.005);  // with the wheels' next 0.05 s
}

TEST(TrackerSteps, TheMotionBeforeAFailureIsTestedAsAStep) {
  // VO fails at frame 8; its motion up to frame 7 turned 4° the gyro did not, certain to
  // 0.1°: the gyro contradicts it, and the wheels carry Δ from VO's reference.
  Tracker t = drive(TrackerOptions{}, Drive{.yaw = 4 / 0.7 * kDeg, .fails_at = 8});
  EXPECT_EQ(t.counts().vo_contradicted, 1);
  EXPECT_NEAR(yawOf(t), 0.0, 0.1 * kDeg);
  EXPECT_NEAR(t.delta().mean.translation().x(), 0.4, 0.01);
}

TEST(TrackerSteps, TheMotionBeforeAFailureGetsTheGyrosYaw) {
  // The same 4° where VO tracked few features and its covariance (3° of yaw) keeps the turn
  // under the gyro's gate: the gyro's yaw is fused in, as into a keyframe step, and takes
  // most of the turn away. Before, the motion before a failure was committed as VO had it.
  Tracker t =
      drive(TrackerOptions{}, Drive{.yaw = 4 / 0.7 * kDeg, .vo_sigma = 0.05, .fails_at = 8});
  EXPECT_EQ(t.counts().vo_contradicted, 0);
  EXPECT_NEAR(yawOf(t), 0.0, 0.2 * kDeg);
}

}  // namespace
}  // namespace evermap::mapper
