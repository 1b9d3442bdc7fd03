// vo-proc around the odometry: the message-level pipeline (calibrations, bad frames, outputs),
// the keyframe_t conversion, the bounded frame queue and the chaining of deltas.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <thread>
#include <vector>

#include "core/messages/convert.h"
#include "core/messages/keyframe_convert.h"
#include "test_data.h"
#include "tools/vo-run/vo_trajectory.h"
#include "vo-proc/frame_queue.h"
#include "vo-proc/vo_pipeline.h"
#include "vo_synthetic.h"

namespace evermap::vo {
namespace {

using core::SE3d;
using core::Vec3;

// The synthetic rig's calibration as already rectified images.
core::StereoCalibration rectifiedCalibration() {
  return testing::rectifiedCalibration(testing::syntheticCamera());
}

evermap::stereo_image_t stereoMsg(int64_t utime, const cv::Mat& l, const cv::Mat& r,
                                  bool rectified = true) {
  auto m = messages::toMsg(messages::StereoFrame{utime, rectified, l, r},
                           messages::ImageEncoding::kGray8);
  EXPECT_TRUE(m.ok());
  return *m;
}

struct Rendered {
  cv::Mat left, right;
};
Rendered render(const SE3d& pose, uint64_t seed) {
  static const testing::TexturedRoom room(testing::dataRoot());
  Rendered r;
  if (!room.ok()) return r;
  cv::RNG rng(seed);
  room.render(testing::syntheticCamera(), pose, &r.left, &r.right, &rng);
  return r;
}

// One output per frame: the start-up hold off (its own tests: vo_self_calibration_test.cpp).
PipelineOptions unheld() {
  PipelineOptions o;
  o.startup_hold_s = 0.0;
  return o;
}

// The one output a frame released.
PipelineOutput one(const PipelineOutputs& outs) {
  EXPECT_EQ(outs.size(), 1u);
  return outs.empty() ? PipelineOutput{} : outs.back();
}

TEST(PipelineOptions, ReachTheFeatureMatchingAndRegistrationOptionsOfCore) {
  PipelineOptions o;
  OptionList list = OptionList::of(&o);
  const OptionField* border = list.find("odometry.features.fast.border_px");
  ASSERT_NE(border, nullptr);
  EXPECT_EQ(border->default_text, "6");
  EXPECT_EQ(border->unit, "px");
  // The odometry's own defaults, not those of a default-constructed core struct.
  ASSERT_NE(list.find("odometry.registration.min_inliers"), nullptr);
  EXPECT_EQ(list.find("odometry.registration.min_inliers")->default_text, "15");
  for (const char* key : {"odometry.matching.search_radius_px", "odometry.rotation.max_angle_rad",
                          "odometry.orb.border_px", "rectifier.alpha", "rgbd.disparity_sigma_px"}) {
    EXPECT_NE(list.find(key), nullptr) << key;
  }
  ASSERT_TRUE(list.set("odometry.registration.motion.min_inliers", "12").ok());
  EXPECT_EQ(o.odometry.registration.motion.min_inliers, 12);
  EXPECT_EQ(list.set("odometry.features.stereo.uniqueness_ratio", "1.5").error().message,
            "option odometry.features.stereo.uniqueness_ratio: 1.5 is outside (0, 1]");
}

TEST(PipelineOptions, ValidateNamesTheKeyOfAValueSetInCodeAndKeepsTheRulesBetweenFields) {
  PipelineOptions o;
  EXPECT_TRUE(o.validate().ok());
  o.odometry.matching.max_refinement_px = 0.0;
  ASSERT_FALSE(o.validate().ok());
  EXPECT_EQ(o.validate().error().message,
            "option odometry.matching.max_refinement_px: 0 is outside > 0");
  o = PipelineOptions{};
  o.odometry.registration.min_inliers = 8;  // below motion.min_inliers (10)
  ASSERT_FALSE(o.validate().ok());
  EXPECT_NE(o.validate().error().message.find("min_inliers"), std::string::npos);
}

TEST(VoPipeline, FramesWithoutAValidCalibrationGetBadInput) {
  const Rendered img = render(SE3d(), 1);
  if (img.left.empty()) GTEST_SKIP() << "room textures not found";
  auto pipeline = VoPipeline::create(unheld());
  ASSERT_TRUE(pipeline.ok());
  // Before any calibration.
  PipelineOutput out = one(pipeline->handleStereo(stereoMsg(10, img.left, img.right)));
  EXPECT_EQ(out.delta.status, +evermap::vo_delta_t::STATUS_BAD_INPUT);
  EXPECT_EQ(out.delta.utime, 10);
  EXPECT_NE(out.result.message.find("no calibration"), std::string::npos);
  // A calibration with NaN intrinsics is refused, naming the field, and frames stay refused.
  evermap::stereo_calib_t nan_calib = messages::toMsg(rectifiedCalibration(), 0);
  nan_calib.left.fx = std::numeric_limits<double>::quiet_NaN();
  const Status refused = pipeline->handleCalibration(nan_calib);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.error().message.find("fx"), std::string::npos) << refused.error().message;
  out = one(pipeline->handleStereo(stereoMsg(20, img.left, img.right)));
  EXPECT_EQ(out.delta.status, +evermap::vo_delta_t::STATUS_BAD_INPUT);
  EXPECT_NE(out.result.message.find("calibration refused"), std::string::npos);
  // A valid calibration: odometry starts.
  ASSERT_TRUE(pipeline->handleCalibration(messages::toMsg(rectifiedCalibration(), 0)).ok());
  out = one(pipeline->handleStereo(stereoMsg(30, img.left, img.right)));
  EXPECT_EQ(out.delta.status, +evermap::vo_delta_t::STATUS_NO_DATA);
  EXPECT_EQ(out.delta.keyframe_changed, 1);
  ASSERT_TRUE(out.keyframe.has_value());
  EXPECT_EQ(out.keyframe->utime, 30);
  EXPECT_DOUBLE_EQ(out.keyframe->fx, 436.0);
  // The same calibration again changes nothing (the reference survives).
  ASSERT_TRUE(pipeline->handleCalibration(messages::toMsg(rectifiedCalibration(), 99)).ok());
  const Rendered moved = render(SE3d(core::SO3d(), Vec3(0.01, 0.0, 0.02)), 2);
  out = one(pipeline->handleStereo(stereoMsg(40, moved.left, moved.right)));
  EXPECT_EQ(out.delta.status, +evermap::vo_delta_t::STATUS_OK) << out.result.message;
  EXPECT_EQ(out.delta.ref_utime, 30);
  EXPECT_NEAR(out.delta.translation[2], 0.02, 0.003);
  EXPECT_NEAR(out.delta.orientation[0], 1.0, 1e-4);
  EXPECT_GT(out.delta.covariance[0], 0.0);
  EXPECT_EQ(pipeline->stats().calibrations, 1);
  EXPECT_EQ(pipeline->stats().calibrations_refused, 1);
}

TEST(VoPipeline, MalformedFramesGetBadInputOrAreCountedAsUndecodable) {
  const Rendered img = render(SE3d(), 3);
  if (img.left.empty()) GTEST_SKIP() << "room textures not found";
  auto pipeline = VoPipeline::create(unheld());
  ASSERT_TRUE(pipeline->handleCalibration(messages::toMsg(rectifiedCalibration(), 0)).ok());
  // Wrong size.
  const cv::Mat small = img.left(cv::Rect(0, 0, 320, 240)).clone();
  PipelineOutput out = one(pipeline->handleStereo(stereoMsg(1, small, small)));
  EXPECT_EQ(out.delta.status, +evermap::vo_delta_t::STATUS_BAD_INPUT);
  EXPECT_NE(out.result.message.find("320x240"), std::string::npos) << out.result.message;
  // A raw pair against a rectified calibration.
  out = one(pipeline->handleStereo(stereoMsg(2, img.left, img.right, /*rectified=*/false)));
  EXPECT_EQ(out.delta.status, +evermap::vo_delta_t::STATUS_BAD_INPUT);
  // An empty image: the message's own validation refuses it.
  evermap::stereo_image_t empty = stereoMsg(3, img.left, img.right);
  empty.left.width = empty.left.height = empty.left.row_stride = empty.left.size = 0;
  empty.left.data.clear();
  out = one(pipeline->handleStereo(empty));
  EXPECT_EQ(out.delta.status, +evermap::vo_delta_t::STATUS_BAD_INPUT);
  // Bytes that are not a stereo_image_t: nothing to publish, counted.
  const std::vector<uint8_t> junk(100, 0x5a);
  EXPECT_FALSE(pipeline->handleStereoBytes(junk.data(), static_cast<int64_t>(junk.size())).ok());
  EXPECT_FALSE(pipeline->handleCalibrationBytes(junk.data(), 7).ok());
  EXPECT_EQ(pipeline->stats().undecodable, 2);
  EXPECT_EQ(pipeline->stats().by_status[static_cast<size_t>(VoStatus::kBadInput)], 3);
  // Good frames still work afterwards, from bytes as vo-proc receives them.
  const evermap::stereo_image_t good = stereoMsg(4, img.left, img.right);
  std::vector<uint8_t> bytes(static_cast<size_t>(good.getEncodedSize()));
  good.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  auto decoded = pipeline->handleStereoBytes(bytes.data(), static_cast<int64_t>(bytes.size()));
  ASSERT_TRUE(decoded.ok());
  EXPECT_EQ(one(*decoded).delta.status, +evermap::vo_delta_t::STATUS_NO_DATA);
}

core::KeyframeFeatures smallKeyframe() {
  core::KeyframeFeatures k;
  k.utime = 1234;
  for (int i = 0; i < 3; ++i) {
    k.keypoints.emplace_back(100.0f + i, 50.5f);
    k.points.emplace_back(0.1f * i, -0.2f, 2.0f + i);
    k.disparity.push_back(24.0f / (2.0f + i));
    k.levels.push_back(static_cast<int8_t>(i));
    core::OrbDescriptor d;
    d.fill(static_cast<uint8_t>(17 * i));
    k.descriptors.push_back(d);
  }
  return k;
}

TEST(KeyframeConvert, RoundTripsAndRefusesMalformedMessages) {
  const core::StereoCamera cam = testing::syntheticCamera();
  const core::KeyframeFeatures k = smallKeyframe();
  const evermap::keyframe_t msg = messages::toMsg(cam, k);
  std::vector<uint8_t> bytes(static_cast<size_t>(msg.getEncodedSize()));
  msg.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  auto decoded = messages::decodeLcm<evermap::keyframe_t>(
      bytes.data(), static_cast<int64_t>(bytes.size()), "KEYFRAME");
  ASSERT_TRUE(decoded.ok()) << decoded.error().message;
  auto back = messages::fromMsg(*decoded);
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(back->features.utime, 1234);
  EXPECT_EQ(back->features.keypoints, k.keypoints);
  EXPECT_EQ(back->features.points, k.points);
  EXPECT_EQ(back->features.levels, k.levels);
  EXPECT_EQ(back->features.descriptors, k.descriptors);
  EXPECT_DOUBLE_EQ(back->camera.baselineM(), cam.baselineM());
  // A claimed count far beyond the bytes: refused before anything is allocated.
  std::vector<uint8_t> lying = bytes;
  lying[56] = 0x7f;  // num_features, big-endian, after hash, utime and five doubles
  EXPECT_FALSE(messages::decodeLcm<evermap::keyframe_t>(lying.data(),
                                                        static_cast<int64_t>(lying.size()), "K")
                   .ok());
  // Field checks.
  evermap::keyframe_t bad = msg;
  bad.points[1][2] = -1.0f;
  EXPECT_FALSE(messages::fromMsg(bad).ok());
  bad = msg;
  bad.fx = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(messages::fromMsg(bad).ok());
  bad = msg;
  bad.descriptors[0].resize(31);
  EXPECT_FALSE(messages::fromMsg(bad).ok());
  bad = msg;
  bad.num_features = 2;
  EXPECT_FALSE(messages::fromMsg(bad).ok());
}

TEST(BoundedQueue, DropsTheOldestWhenFullAndCountsThem) {
  BoundedQueue<int> q(3);
  for (int i = 1; i <= 5; ++i) q.push(i);
  EXPECT_EQ(q.size(), 3u);
  EXPECT_EQ(q.dropped(), 2);
  EXPECT_EQ(q.pushed(), 5);
  EXPECT_EQ(*q.pop(), 3);  // 1 and 2 were dropped
  // The element dropped is handed back when asked for (vo-proc names the frame it lost).
  std::optional<int> dropped;
  q.push(10, &dropped);
  EXPECT_FALSE(dropped.has_value());  // there was room
  q.push(11, &dropped);
  EXPECT_EQ(dropped, 4);
  EXPECT_EQ(*q.pop(), 5);
  EXPECT_EQ(*q.pop(), 10);
  EXPECT_EQ(*q.pop(), 11);
  for (int i = 4; i <= 5; ++i) q.push(i);
  // A consumer on another thread gets everything pushed after, then the end.
  std::vector<int> got;
  std::thread consumer([&] {
    while (auto v = q.pop()) got.push_back(*v);
  });
  q.push(6);
  q.close();
  consumer.join();
  EXPECT_EQ(got, (std::vector<int>{4, 5, 6}));
  EXPECT_FALSE(q.push(7));
}

TEST(BoundedQueue, InWaitModeAProducerAheadOfItsConsumerLosesNothing) {
  // evermap-slam-run's reader: it waits for room instead of dropping.
  BoundedQueue<int> q(2, BoundedQueue<int>::Full::kWait);
  std::thread producer([&] {
    for (int i = 0; i < 1000; ++i) ASSERT_TRUE(q.push(i));
    q.close();
  });
  std::vector<int> got;
  while (auto v = q.pop()) {
    EXPECT_LE(q.size(), 2u);
    got.push_back(*v);
  }
  producer.join();
  ASSERT_EQ(got.size(), 1000u);
  for (int i = 0; i < 1000; ++i) EXPECT_EQ(got[static_cast<size_t>(i)], i);
  EXPECT_EQ(q.dropped(), 0);
  // A producer waiting on a full queue is released by close().
  BoundedQueue<int> full(1, BoundedQueue<int>::Full::kWait);
  ASSERT_TRUE(full.push(1));
  std::thread blocked([&] { EXPECT_FALSE(full.push(2)); });
  full.close();
  blocked.join();
}

evermap::vo_delta_t delta(int64_t utime, int64_t ref, int8_t status, bool changed,
                          const Vec3& t = Vec3::Zero()) {
  FrameResult r;
  r.utime = utime;
  r.ref_utime = ref;
  r.status = static_cast<VoStatus>(status);
  r.keyframe_changed = changed;
  r.ref_T_cur = SE3d(core::SO3d(), t);
  return toMsg(r);
}

TEST(VoTrajectory, ChainsKeyframesAndBridgesFailures) {
  using D = evermap::vo_delta_t;
  VoTrajectory chain;
  EXPECT_FALSE(chain.add(delta(1, 1, D::STATUS_INSUFFICIENT_FEATURES, false)));  // not started
  EXPECT_TRUE(chain.add(delta(2, 2, D::STATUS_NO_DATA, true))->translation().isZero());
  EXPECT_NEAR(chain.add(delta(3, 2, D::STATUS_OK, false, Vec3(1, 0, 0)))->translation().x(), 1,
              1e-12);
  // New keyframe at 4, 2 m from 2.
  EXPECT_NEAR(chain.add(delta(4, 2, D::STATUS_OK, true, Vec3(2, 0, 0)))->translation().x(), 2,
              1e-12);
  EXPECT_NEAR(chain.add(delta(5, 4, D::STATUS_OK, false, Vec3(0, 1, 0)))->translation().y(), 1,
              1e-12);
  // Failure, then the reference is replaced by frame 7 without a motion: a break.
  EXPECT_FALSE(chain.add(delta(6, 4, D::STATUS_INSUFFICIENT_INLIERS, false)));
  EXPECT_FALSE(chain.add(delta(7, 4, D::STATUS_INSUFFICIENT_INLIERS, true)));
  EXPECT_EQ(chain.breaks(), 1);
  const auto p = chain.add(delta(8, 7, D::STATUS_OK, false, Vec3(0, 0, 1)));
  ASSERT_TRUE(p);
  EXPECT_TRUE(p->translation().isApprox(Vec3(2, 1, 1)));  // from the last known pose
  EXPECT_EQ(chain.posed(), 5);
}

}  // namespace
}  // namespace evermap::vo
