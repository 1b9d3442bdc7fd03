// core/messages/odometry_frame.h: the odometry frames of a VO_DELTA and a WHEEL_ODOM stream,
// and the motion between two of their poses with the covariance of the increments between them.

#include "core/messages/odometry_frame.h"

#include <gtest/gtest.h>

#include <deque>
#include <limits>
#include <random>
#include <vector>

#include "core/messages/pose_fields.h"

namespace evermap::messages {
namespace {

using core::Mat6;
using core::SE3d;
using core::UncertainPose;
using core::Vec6;

vo_delta_t frame(int64_t utime, int64_t ref, const UncertainPose& ref_T_cur, bool keyframe,
                 int8_t status = vo_delta_t::STATUS_OK) {
  vo_delta_t m{};
  m.utime = utime;
  m.ref_utime = ref;
  m.status = status;
  m.keyframe_changed = keyframe ? 1 : 0;
  putPose(ref_T_cur.mean, m.translation, m.orientation);
  for (int r = 0; r < 6; ++r)
    for (int c = 0; c < 6; ++c) m.covariance[6 * r + c] = ref_T_cur.covariance(r, c);
  return m;
}

vo_delta_t restart(int64_t utime) {
  return frame(utime, utime, UncertainPose{}, true, vo_delta_t::STATUS_NO_DATA);
}

// A random motion of a few decimetres and degrees with a random covariance.
UncertainPose randomMotion(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Vec6 xi;
  for (int i = 0; i < 6; ++i) xi[i] = (i < 3 ? 0.3 : 0.05) * n(rng);
  Eigen::Matrix<double, 6, 6> a;
  for (int r = 0; r < 6; ++r)
    for (int c = 0; c < 6; ++c) a(r, c) = 1e-3 * n(rng);
  return UncertainPose{SE3d::exp(xi), a * a.transpose() + 1e-6 * Mat6::Identity()};
}

double relativeError(const Mat6& a, const Mat6& b) { return (a - b).norm() / b.norm(); }

TEST(OdometryFrame, EachFrameCarriesItsKeyframeChainComposedWithItsCovariance) {
  std::mt19937 rng(1);
  OdometryFrame odom;
  vo_delta_t m = restart(100);
  odom.stamp(m);
  EXPECT_EQ(m.odom_epoch, 100);
  UncertainPose chain;  // odom_T_ref, compounded here by hand
  int64_t ref = 100;
  for (int64_t t = 200; t <= 2000; t += 100) {
    const UncertainPose motion = randomMotion(rng);
    const bool keyframe = (t / 100) % 3 == 0;
    m = frame(t, ref, motion, keyframe);
    odom.stamp(m);
    const UncertainPose expected = core::compound(chain, motion);
    ASSERT_EQ(m.odom_epoch, 100) << t;
    auto p = odometryPose(m);
    ASSERT_TRUE(p);
    EXPECT_LT((p->odom_T_cam.mean.inverse() * expected.mean).log().norm(), 1e-9) << t;
    EXPECT_LT(relativeError(p->odom_T_cam.covariance, expected.covariance), 1e-9) << t;
    if (keyframe) {
      chain = expected;
      ref = t;
    }
  }
}

// The mapper's use: a frame a saved (a keyframe or a frame riding on one) and a frame b many
// keyframes later. odometryBetween's covariance is that of compounding the increments from a
// to b one by one, as a tracker that received them would have.
TEST(OdometryFrame, TheMotionBetweenTwoFramesHasTheCovarianceOfTheIncrementsBetweenThem) {
  for (const bool a_is_keyframe : {true, false}) {
    std::mt19937 rng(a_is_keyframe ? 7 : 8);
    OdometryFrame odom;
    vo_delta_t m = restart(1000);
    odom.stamp(m);
    std::vector<UncertainPose> keyframe_steps;  // ref_T_keyframe of each keyframe change
    int64_t ref = 1000;
    int64_t t = 1000;
    auto step = [&](bool keyframe) {
      t += 100;
      const UncertainPose motion = randomMotion(rng);
      m = frame(t, ref, motion, keyframe);
      odom.stamp(m);
      if (keyframe) ref = t;
      return motion;
    };
    for (int k = 0; k < 5; ++k) keyframe_steps.push_back(step(true));  // a long chain before a
    const UncertainPose k_T_a = step(a_is_keyframe);
    if (a_is_keyframe) keyframe_steps.push_back(k_T_a);
    const auto a = odometryPose(m);
    const Mat6 a_own = a_is_keyframe ? Mat6::Zero() : k_T_a.covariance;
    ASSERT_TRUE(a);
    // From a (or its keyframe k) on: keyframes, then b riding on the last one.
    UncertainPose expected = a_is_keyframe ? UncertainPose{} : core::invert(k_T_a);
    for (int k = 0; k < 6; ++k) expected = core::compound(expected, step(true));
    expected = core::compound(expected, step(false));
    const auto b = odometryPose(m);
    ASSERT_TRUE(b);
    auto between = odometryBetween(*a, a_own, *b);
    ASSERT_TRUE(between) << between.error().message;
    EXPECT_LT((between->mean.inverse() * expected.mean).log().norm(), 1e-9);
    EXPECT_LT(relativeError(between->covariance, expected.covariance), 1e-6)
        << (a_is_keyframe ? "keyframe" : "frame");
    // Without a's own covariance added back, a frame riding on its keyframe would count too
    // little: the check above would fail.
    if (!a_is_keyframe) {
      auto short_of = odometryBetween(*a, Mat6::Zero(), *b);
      EXPECT_GT(relativeError(short_of->covariance, expected.covariance), 1e-3);
    }
  }
}

TEST(OdometryFrame, AChainRestartStartsANewEpochAndAFailureKeepsItWithoutAPose) {
  std::mt19937 rng(3);
  OdometryFrame odom;
  vo_delta_t m = restart(100);
  odom.stamp(m);
  m = frame(200, 100, randomMotion(rng), true);
  odom.stamp(m);
  const auto before = odometryPose(m);
  ASSERT_TRUE(before);
  // A passer-by: VO keeps its reference, the frame has no pose, the epoch goes on.
  m = frame(300, 200, UncertainPose{}, false, vo_delta_t::STATUS_INSUFFICIENT_INLIERS);
  odom.stamp(m);
  EXPECT_EQ(m.odom_epoch, 0);
  EXPECT_FALSE(odometryPose(m));
  m = frame(400, 200, randomMotion(rng), false);
  odom.stamp(m);
  const auto after = odometryPose(m);
  ASSERT_TRUE(after);
  EXPECT_EQ(after->epoch, 100);
  EXPECT_TRUE(odometryBetween(*before, Mat6::Zero(), *after));
  // A chain break (a failure that makes the frame the new reference), then VO's restart.
  m = frame(500, 500, UncertainPose{}, true, vo_delta_t::STATUS_INSUFFICIENT_FEATURES);
  odom.stamp(m);
  EXPECT_EQ(m.odom_epoch, 500);
  m = restart(600);
  odom.stamp(m);
  const auto restarted = odometryPose(m);
  ASSERT_TRUE(restarted);
  EXPECT_EQ(restarted->epoch, 600);
  EXPECT_LT(restarted->odom_T_cam.mean.log().norm(), 1e-12);
  auto across = odometryBetween(*after, Mat6::Zero(), *restarted);
  ASSERT_FALSE(across);
  EXPECT_NE(across.error().message.find("epochs differ"), std::string::npos);
  // A frame on a reference the stream never showed: no pose until a keyframe starts an epoch.
  m = frame(700, 650, randomMotion(rng), false);
  odom.stamp(m);
  EXPECT_EQ(m.odom_epoch, 0);
  m = frame(800, 650, randomMotion(rng), true);
  odom.stamp(m);
  EXPECT_EQ(m.odom_epoch, 800);
}

TEST(OdometryFrame, AMalformedPoseIsNoPose) {
  vo_delta_t m = restart(100);
  OdometryFrame odom;
  odom.stamp(m);
  ASSERT_TRUE(odometryPose(m));
  vo_delta_t bad = m;
  bad.odom_orientation[0] = 2.0;
  std::string why;
  EXPECT_FALSE(odometryPose(bad, &why));
  EXPECT_NE(why.find("quaternion"), std::string::npos);
  bad = m;
  bad.odom_covariance[0] = -1.0;
  EXPECT_FALSE(odometryPose(bad, &why));
  EXPECT_NE(why.find("covariance"), std::string::npos);
  bad = m;
  bad.odom_translation[1] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(odometryPose(bad));
}

// A wheel increment of a few centimetres and degrees (10 Hz at a walking pace) with a random
// covariance.
wheel_odom_t wheelIncrement(std::mt19937& rng, int64_t prev_utime, int64_t utime) {
  std::normal_distribution<double> n(0.0, 1.0);
  wheel_odom_t m{};
  m.prev_utime = prev_utime;
  m.utime = utime;
  m.delta_x_m = 0.05 + 0.01 * n(rng);
  m.delta_y_m = 0.005 * n(rng);
  m.delta_theta_rad = 0.05 * n(rng);
  Eigen::Matrix3d a;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) a(r, c) = 1e-3 * n(rng);
  const Eigen::Matrix3d cov = a * a.transpose() + 1e-8 * Eigen::Matrix3d::Identity();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) m.covariance[3 * r + c] = cov(r, c);
  return m;
}

Eigen::Matrix3d covarianceOf(const wheel_odom_t& m) {
  Eigen::Matrix3d c;
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 3; ++k) c(r, k) = m.covariance[3 * r + k];
  return c;
}

// The wheels' odometry pose is the increments compounded (SSC), and the motion between two
// poses of the stream has the mean and covariance of compounding the increments between them
// alone: what a consumer that missed them would have accumulated.
TEST(WheelOdometryFrame, TheMotionBetweenTwoPosesIsTheIncrementsBetweenThemWithTheirCovariance) {
  std::mt19937 rng(5);
  WheelOdometryFrame odom;
  std::vector<wheel_odom_t> stream;
  for (int k = 0; k < 200; ++k) {
    stream.push_back(wheelIncrement(rng, 1'000'000 + 100'000 * k, 1'000'000 + 100'000 * (k + 1)));
    odom.stamp(stream.back());
    EXPECT_EQ(stream.back().odom_epoch, 1'000'000);
  }
  for (const auto& [i, j] : {std::pair{0, 1}, std::pair{10, 60}, std::pair{37, 199}}) {
    const auto a = wheelOdometryPose(stream[i]);
    const auto b = wheelOdometryPose(stream[j]);
    ASSERT_TRUE(a && b);
    const auto d = wheelOdometryBetween(*a, *b);
    ASSERT_TRUE(d) << d.error().message;
    // The increments i+1..j compounded from the identity with zero covariance.
    core::SE2d pose;
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    for (int k = i + 1; k <= j; ++k) {
      Eigen::Matrix3d j1, j2;
      const core::SE2d inc(stream[k].delta_x_m, stream[k].delta_y_m, stream[k].delta_theta_rad);
      pose = core::compose(pose, inc, &j1, &j2);
      cov = j1 * cov * j1.transpose() + j2 * covarianceOf(stream[k]) * j2.transpose();
    }
    EXPECT_LT((d->a_T_b.vector() - pose.vector()).norm(), 1e-9) << i << "-" << j;
    EXPECT_LT((d->covariance - cov).norm() / cov.norm(), 1e-6) << i << "-" << j;
  }
  // Across poses of one time, and backwards: zero motion, then an error.
  const auto p = wheelOdometryPose(stream[5]);
  EXPECT_LT(wheelOdometryBetween(*p, *p)->a_T_b.vector().norm(), 1e-12);
  EXPECT_FALSE(wheelOdometryBetween(*wheelOdometryPose(stream[6]), *p));
}

// An increment that does not start where the last ended (a hole: motion nothing measured) or
// is no motion starts a new epoch; poses of two epochs have no motion between them.
TEST(WheelOdometryFrame, AHoleInTheStreamStartsANewEpoch) {
  std::mt19937 rng(6);
  WheelOdometryFrame odom;
  wheel_odom_t a = wheelIncrement(rng, 100, 200);
  odom.stamp(a);
  wheel_odom_t b = wheelIncrement(rng, 200, 300);
  odom.stamp(b);
  EXPECT_EQ(b.odom_epoch, 100);
  wheel_odom_t c = wheelIncrement(rng, 400, 500);  // 300-400 missing
  odom.stamp(c);
  EXPECT_EQ(c.odom_epoch, 400);
  auto across = wheelOdometryBetween(*wheelOdometryPose(b), *wheelOdometryPose(c));
  ASSERT_FALSE(across);
  EXPECT_NE(across.error().message.find("epochs differ"), std::string::npos);
  wheel_odom_t bad = wheelIncrement(rng, 500, 600);
  bad.delta_x_m = std::numeric_limits<double>::quiet_NaN();
  odom.stamp(bad);
  EXPECT_EQ(bad.odom_epoch, 0);
  EXPECT_FALSE(wheelOdometryPose(bad));
  wheel_odom_t d = wheelIncrement(rng, 600, 700);
  odom.stamp(d);
  EXPECT_EQ(d.odom_epoch, 600);
  // A malformed pose field is no pose, and says why.
  wheel_odom_t e = d;
  e.odom_covariance[1] = 1.0;  // not symmetric
  std::string why;
  EXPECT_FALSE(wheelOdometryPose(e, &why));
  EXPECT_NE(why.find("covariance"), std::string::npos);
  e = d;
  e.odom_theta_rad = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(wheelOdometryPose(e, &why));
}

// The pose at a time between two messages is their motion's share at constant rate; past the
// newest it is extrapolated at the last increment's rate, with more variance, for at most two
// increments' lengths; before the oldest, or across epochs, there is none.
TEST(WheelOdometryFrame, APoseBetweenOrJustPastTheMessagesIsInterpolatedAtConstantRate) {
  WheelOdometryFrame odom;
  std::deque<WheelOdometryPose> poses;
  for (int k = 0; k < 3; ++k) {
    wheel_odom_t m{};
    m.prev_utime = 1000 + 100 * k;
    m.utime = m.prev_utime + 100;
    m.delta_x_m = 0.1;  // a steady turn: 0.1 m and 0.1 rad per 100 µs
    m.delta_theta_rad = 0.1;
    m.covariance[0] = m.covariance[4] = 1e-4;
    m.covariance[8] = 1e-6;
    odom.stamp(m);
    poses.push_back(*wheelOdometryPose(m));
  }
  // Halfway between the first two poses (1100, 1200): half the twist.
  const auto mid = wheelOdometryAt(poses, 1150);
  ASSERT_TRUE(mid);
  const core::SE2d expected =
      core::compose(poses[0].odom_T_body, core::SE2d::exp(0.5 * core::SE2d(0.1, 0, 0.1).log()));
  EXPECT_LT((mid->odom_T_body.vector() - expected.vector()).norm(), 1e-12);
  EXPECT_GT(mid->covariance(0, 0), poses[0].covariance(0, 0));
  EXPECT_LT(mid->covariance(0, 0), poses[1].covariance(0, 0));
  EXPECT_EQ(wheelOdometryAt(poses, 1200)->utime, 1200);
  // Past the newest, on the same arc.
  const auto ahead = wheelOdometryAt(poses, 1350);
  ASSERT_TRUE(ahead);
  EXPECT_NEAR(ahead->odom_T_body.theta(), 0.35, 1e-12);
  EXPECT_GT(ahead->covariance(0, 0), poses[2].covariance(0, 0));
  EXPECT_FALSE(wheelOdometryAt(poses, 1501));       // more than two increments past
  EXPECT_FALSE(wheelOdometryAt(poses, 1099));       // before the oldest
  EXPECT_FALSE(wheelOdometryAt({poses[1]}, 1250));  // one pose: only its own time
  EXPECT_TRUE(wheelOdometryAt({poses[1]}, 1200));
}

}  // namespace
}  // namespace evermap::messages
