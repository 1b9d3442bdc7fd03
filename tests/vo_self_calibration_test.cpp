// Self-calibration of the disparity offset inside StereoOdometry (core/registration/
// disparity_offset_tracker.h), on rendered stereo of the textured room (tests/vo_synthetic.h)
// with a calibration deliberately wrong by a known offset: the odometry finds it and moves its
// camera there; with the right calibration it stays at exactly 0.
#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include <opencv2/core.hpp>

#include "core/camera/stereo_camera.h"
#include "test_data.h"
#include "vo-proc/stereo_odometry.h"
#include "vo_synthetic.h"

namespace evermap::vo {
namespace {

#define REQUIRE_ROOM(room)                                                          \
  const testing::TexturedRoom room(testing::dataRoot());                            \
  if (!room.ok()) {                                                                 \
    if (testing::underCi()) FAIL() << "room textures not found";                    \
    GTEST_SKIP() << "room textures (kitti07-mono-160, euroc-v101-micro) not found"; \
  }

struct WalkResult {
  double offset_px = 0.0;  // the camera's offset at the end
  double row_slope = 0.0;  // and its row slope
  int decisions = 0;       // rounds decided
  int applied = 0;
  int tracked = 0;
};

// 40 frames walking 8 cm each through the room, swaying and turning a little, rendered with
// the exact rig; the right image shifted right by `right_shift_px` whole pixels, then each row
// by `right_slope` x (row - cy); odometry with `camera` (whose offset may be wrong).
WalkResult walk(const testing::TexturedRoom& room, const core::StereoCamera& camera,
                int right_shift_px, double right_slope = 0.0) {
  const core::StereoCamera rendered = testing::syntheticCamera();
  // Every frame becomes the reference, so that each pair is of another reference frame (its
  // own group): evidence from 40 frames that a hovering reference would spread over more.
  OdometryOptions options;
  options.keyframe_inlier_threshold = 100000;
  auto odometry = StereoOdometry::create(camera, options);
  EXPECT_TRUE(odometry.ok());
  cv::RNG rng(11);
  WalkResult run;
  for (int k = 0; k < 40; ++k) {
    const core::SE3d world_T_cam(core::SO3d::exp(core::Vec3(0.0, 0.2 * std::sin(0.1 * k), 0.0)),
                                 core::Vec3(0.4 * std::sin(0.15 * k), 0.1, -2.8 + 0.08 * k));
    cv::Mat left, right;
    room.render(rendered, world_T_cam, &left, &right, &rng);
    right = testing::shiftedRight(right, right_shift_px);
    if (right_slope != 0.0) right = testing::shearedRight(right, right_slope, rendered.cy());
    const FrameResult r = odometry->process(1000000 + 50000 * int64_t(k), left, right);
    run.tracked += r.ok() ? 1 : 0;
    if (!r.calibration_message.empty()) {
      std::printf("frame %d: %s\n", k, r.calibration_message.c_str());
      ++run.decisions;
      run.applied += r.calibration_changed ? 1 : 0;
    }
  }
  run.offset_px = odometry->camera().disparityOffsetPx();
  run.row_slope = odometry->camera().disparityRowSlope();
  return run;
}

TEST(SelfCalibration, ACorrectRigStaysAtExactlyZero) {
  REQUIRE_ROOM(room);
  const WalkResult run = walk(room, testing::syntheticCamera(), 0);
  EXPECT_GE(run.tracked, 38);
  EXPECT_GE(run.decisions, 1);  // it had the evidence, and kept the calibration
  EXPECT_EQ(run.applied, 0);
  EXPECT_EQ(run.offset_px, 0.0);
  EXPECT_EQ(run.row_slope, 0.0);
}

TEST(SelfCalibration, ARightImageOnePixelOffItsCalibrationIsFound) {
  REQUIRE_ROOM(room);
  const WalkResult run = walk(room, testing::syntheticCamera(), 1);
  EXPECT_GE(run.tracked, 38);
  EXPECT_GE(run.applied, 1);
  EXPECT_NEAR(run.offset_px, 1.0, 0.15);
  EXPECT_EQ(run.row_slope, 0.0);  // a constant offset: no slope applied
}

TEST(SelfCalibration, ARightImageWhoseRowsShiftWithTheirHeightHasItsSlopeFound) {
  // 0.004 px per row (the KITTI clip's): +-0.96 px at the top and bottom rows, 0 at cy.
  REQUIRE_ROOM(room);
  const WalkResult run = walk(room, testing::syntheticCamera(), 0, 0.004);
  EXPECT_GE(run.tracked, 38);
  EXPECT_GE(run.applied, 1);
  EXPECT_NEAR(run.row_slope, 0.004, 0.0008);
  EXPECT_NEAR(run.offset_px, 0.0, 0.15);
}

TEST(SelfCalibration, ACalibrationThatClaimsAnOffsetTheImagesDoNotHaveIsUndone) {
  REQUIRE_ROOM(room);
  const core::StereoCamera exact = testing::syntheticCamera();
  const core::StereoCamera wrong =
      *core::StereoCamera::create(exact.fx(), exact.fy(), exact.cx(), exact.cy(), exact.baselineM(),
                                  exact.width(), exact.height(), -0.7);
  const WalkResult run = walk(room, wrong, 0);
  EXPECT_GE(run.tracked, 38);
  EXPECT_GE(run.applied, 1);
  EXPECT_NEAR(run.offset_px, 0.0, 0.15);
}

TEST(SelfCalibration, IsOffWhenAskedAndRefusesBadOptions) {
  REQUIRE_ROOM(room);
  OdometryOptions off;
  off.self_calibrate = false;
  auto odometry = StereoOdometry::create(testing::syntheticCamera(), off);
  ASSERT_TRUE(odometry.ok());
  EXPECT_FALSE(odometry->selfCalibration().has_value());
  OdometryOptions bad;
  bad.self_calibration.evidence.min_groups = 2;
  EXPECT_FALSE(StereoOdometry::create(testing::syntheticCamera(), bad).ok());
  bad = OdometryOptions{};
  bad.self_calibration.evidence.max_pairs = 4;  // below min_pairs
  EXPECT_FALSE(StereoOdometry::create(testing::syntheticCamera(), bad).ok());
}

}  // namespace
}  // namespace evermap::vo
