// vo-proc's fast-motion retry (OdometryOptions::fast_motion_fraction): the registration options
// a frame that failed at fast rotation is retried with, and which cameras retry by default.
#include <gtest/gtest.h>

#include <numbers>

#include "vo-proc/stereo_odometry.h"
#include "vo-proc/vo_pipeline.h"

namespace evermap::vo {
namespace {

using core::SE3d;

constexpr double kFx = 500.0;

core::RegistrationOptions bounds(double inlier_px, double mean_px) {
  core::RegistrationOptions o;
  o.motion.inlier_max_reprojection_px = inlier_px;
  o.motion.max_mean_reprojection_px = mean_px;
  return o;
}

SE3d turn(double degrees) {
  return SE3d(core::SO3d::exp(core::Vec3(0.0, degrees * std::numbers::pi / 180.0, 0.0)),
              core::Vec3(0.01, 0.0, 0.0));
}

TEST(VoFastMotion, WidensBothBoundsToTheFractionOfThePredictedImageMotion) {
  // 4 degrees at fx 500: 34.9 px of image motion; 0.15 of it is 5.24 px, 2.62x the 2 px bound.
  const auto widened = fastMotionRegistration(bounds(2.0, 1.5), kFx, turn(4.0), 0.15);
  ASSERT_TRUE(widened.has_value());
  const double image_px = kFx * 4.0 * std::numbers::pi / 180.0;
  EXPECT_NEAR(widened->motion.inlier_max_reprojection_px, 0.15 * image_px, 1e-9);
  EXPECT_NEAR(widened->motion.max_mean_reprojection_px, 1.5 * 0.15 * image_px / 2.0, 1e-9);
}

TEST(VoFastMotion, KeepsEverythingButTheTwoBounds) {
  core::RegistrationOptions o = bounds(2.0, 2.0);
  o.min_inliers = 17;
  o.motion.min_inliers = 11;
  o.clique.threshold_m = 0.07;
  const auto widened = fastMotionRegistration(o, kFx, turn(6.0), 0.15);
  ASSERT_TRUE(widened.has_value());
  EXPECT_EQ(widened->min_inliers, 17);
  EXPECT_EQ(widened->motion.min_inliers, 11);
  EXPECT_EQ(widened->clique.threshold_m, 0.07);
}

TEST(VoFastMotion, DoesNotRetryAFrameWhoseMotionTheBoundsAlreadyAllow) {
  // 1 degree: 8.7 px of image motion, 0.15 of it 1.3 px, below the 2 px bound: the frame failed
  // for another reason than its motion.
  EXPECT_FALSE(fastMotionRegistration(bounds(2.0, 2.0), kFx, turn(1.0), 0.15).has_value());
  // Translation alone predicts no rotation: nothing to widen for.
  EXPECT_FALSE(fastMotionRegistration(bounds(2.0, 2.0), kFx, turn(0.0), 0.15).has_value());
}

TEST(VoFastMotion, IsOffWithAZeroFraction) {
  EXPECT_FALSE(fastMotionRegistration(bounds(2.0, 2.0), kFx, turn(30.0), 0.0).has_value());
}

TEST(VoFastMotion, IsOnForRgbdCamerasAndOffForStereoRigsByDefault) {
  const PipelineOptions options;
  EXPECT_EQ(options.odometry.fast_motion_fraction, 0.0);  // global-shutter stereo: unchanged
  EXPECT_GT(options.rgbd_fast_motion_fraction, 0.0);      // the Kinect's rolling shutter, blur
}

}  // namespace
}  // namespace evermap::vo
