// core/registration/disparity_offset.h on synthetic stereo of a textured room
// (tests/vo_synthetic.h): an exact rig gives offset 0, a right image shifted by one pixel
// (its principal point 1 px from the calibration's) gives +1, and a wrong baseline, which
// only scales the points, gives 0 as well.
#include <gtest/gtest.h>

#include <cstdio>

#include <opencv2/core.hpp>

#include "core/features/orb_descriptor.h"
#include "core/features/stereo_features.h"
#include "core/registration/frame_registration.h"
#include "core/registration/keyframe_features.h"
#include "test_data.h"
#include "core/registration/disparity_offset.h"
#include "vo_synthetic.h"

namespace evermap::core {
namespace {

// Frames moving forward 0.25 m each through the room, turning slightly; the right image is
// moved right by `right_shift_px` whole pixels (0: exact). Returns the registered consecutive
// pairs measured with `camera` (which may differ from the rig that rendered them).
std::vector<StereoMatchPair> forwardPairs(const testing::TexturedRoom& room,
                                          const StereoCamera& rendered, const StereoCamera& camera,
                                          int right_shift_px) {
  auto extractor = StereoFeatureExtractor::create(StereoFeatureExtractor::Options{});
  EXPECT_TRUE(extractor.ok());
  OrbExtractor orb{OrbExtractor::Options{}};
  cv::RNG rng(7);
  std::vector<StereoMatchPair> pairs;
  KeyframeFeatures previous;
  for (int k = 0; k < 8; ++k) {
    const SE3d world_T_cam(SO3d::exp(Vec3(0.0, 0.02 * k, 0.0)),
                           Vec3(0.1 * k, 0.1, -2.5 + 0.25 * k));
    cv::Mat left, right;
    room.render(rendered, world_T_cam, &left, &right, &rng);
    right = testing::shiftedRight(right, right_shift_px);
    FeatureFrame frame;
    EXPECT_TRUE(extractor->extract(camera, k, left, right, &frame).ok());
    KeyframeFeatures kf = makeKeyframeFeatures(frame, orb);
    if (k > 0) {
      const RegistrationSummary s =
          registerFrames(camera, previous, camera, kf, RegistrationOptions{});
      EXPECT_TRUE(s.ok()) << s.message;
      pairs.push_back(matchPair(previous, kf, s));
    }
    previous = std::move(kf);
  }
  return pairs;
}

// The offset that `camera` estimates from `pairs` with the default options is `expected_px`
// within 0.15 px; the summary goes to *out.
void expectOffset(const StereoCamera& camera, const std::vector<StereoMatchPair>& pairs,
                  double expected_px, DisparityOffsetSummary* out = nullptr) {
  const auto est = estimateDisparityOffset(camera, pairs, DisparityOffsetOptions{});
  ASSERT_TRUE(est.ok()) << est.error().message;
  std::printf("%s\n", est->message.c_str());
  EXPECT_NEAR(est->offset_px, expected_px, 0.15) << est->message;
  if (out != nullptr) *out = *est;
}

#define REQUIRE_ROOM(room)                                                          \
  const testing::TexturedRoom room(testing::dataRoot());                            \
  if (!room.ok()) {                                                                 \
    if (testing::underCi()) FAIL() << "room textures not found";                    \
    GTEST_SKIP() << "room textures (kitti07-mono-160, euroc-v101-micro) not found"; \
  }

TEST(DisparityOffset, AnExactRigHasNoOffset) {
  REQUIRE_ROOM(room);
  const StereoCamera camera = testing::syntheticCamera();
  DisparityOffsetSummary est;
  ASSERT_NO_FATAL_FAILURE(expectOffset(camera, forwardPairs(room, camera, camera, 0), 0.0, &est));
  EXPECT_EQ(est.pairs, 7);
}

TEST(DisparityOffset, ARightImageOnePixelOffFromItsCalibrationIsFound) {
  REQUIRE_ROOM(room);
  const StereoCamera camera = testing::syntheticCamera();
  expectOffset(camera, forwardPairs(room, camera, camera, 1), 1.0);
}

TEST(DisparityOffset, AWrongBaselineIsNotMistakenForAnOffset) {
  REQUIRE_ROOM(room);
  const StereoCamera rendered = testing::syntheticCamera();
  const StereoCamera measured =
      *StereoCamera::create(rendered.fx(), rendered.fy(), rendered.cx(), rendered.cy(),
                            rendered.baselineM() * 1.08, rendered.width(), rendered.height());
  expectOffset(measured, forwardPairs(room, rendered, measured, 0), 0.0);
}

TEST(DisparityOffset, RefusesAGridWhoseEndIsTheMinimumAndEmptyInput) {
  REQUIRE_ROOM(room);
  const StereoCamera camera = testing::syntheticCamera();
  DisparityOffsetOptions narrow;
  narrow.min_offset_px = 1.5;
  narrow.max_offset_px = 3.0;
  EXPECT_FALSE(estimateDisparityOffset(camera, forwardPairs(room, camera, camera, 0), narrow).ok());
  EXPECT_FALSE(estimateDisparityOffset(camera, {}, DisparityOffsetOptions{}).ok());
  DisparityOffsetOptions bad;
  bad.step_px = 0.0;
  EXPECT_FALSE(bad.validate().ok());
}

}  // namespace
}  // namespace evermap::core
