// core/messages/odometry_frame.h: the odometry frame of a VO_DELTA stream, and the motion
// between two of its frames with the covariance of the increments between them.

#include "core/messages/odometry_frame.h"

#include <gtest/gtest.h>

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

vo_delta_t restart(int64_t utime) { return frame(utime, utime, UncertainPose{}, true, vo_delta_t::STATUS_NO_DATA); }

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
    EXPECT_LT(relativeError(between->covariance, expected.covariance), 1e-6) << (a_is_keyframe ? "keyframe" : "frame");
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

}  // namespace
}  // namespace evermap::messages
