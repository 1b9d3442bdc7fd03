// Self-calibration of the disparity offset inside StereoOdometry (core/registration/
// disparity_offset_tracker.h), on rendered stereo of the textured room (tests/vo_synthetic.h)
// with a calibration deliberately wrong by a known offset: the odometry finds it and moves its
// camera there; with the right calibration it stays at exactly 0.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "core/camera/stereo_camera.h"
#include "core/messages/convert.h"
#include "test_data.h"
#include "vo-proc/stereo_odometry.h"
#include "vo-proc/vo_pipeline.h"
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

// 40 frames 50 ms apart walking 8 cm each through the room, swaying and turning a little,
// rendered with the exact rig; the right image shifted right by `right_shift_px` whole pixels,
// then each row by `right_slope` x (row - cy).
struct Frame {
  int64_t utime = 0;
  cv::Mat left, right;
};
std::vector<Frame> renderWalk(const testing::TexturedRoom& room, int right_shift_px,
                              double right_slope = 0.0) {
  const core::StereoCamera rendered = testing::syntheticCamera();
  cv::RNG rng(11);
  std::vector<Frame> frames;
  for (int k = 0; k < 40; ++k) {
    const core::SE3d world_T_cam(core::SO3d::exp(core::Vec3(0.0, 0.2 * std::sin(0.1 * k), 0.0)),
                                 core::Vec3(0.4 * std::sin(0.15 * k), 0.1, -2.8 + 0.08 * k));
    Frame f;
    f.utime = 1000000 + 50000 * int64_t(k);
    room.render(rendered, world_T_cam, &f.left, &f.right, &rng);
    f.right = testing::shiftedRight(f.right, right_shift_px);
    if (right_slope != 0.0) f.right = testing::shearedRight(f.right, right_slope, rendered.cy());
    frames.push_back(std::move(f));
  }
  return frames;
}

// Every frame becomes the reference, so that each pair is of another reference frame (its
// own group): evidence from 40 frames that a hovering reference would spread over more.
OdometryOptions walkOptions() {
  OdometryOptions options;
  options.keyframe_inlier_threshold = 100000;
  return options;
}

// The walk through odometry with `camera` (whose offset may be wrong).
WalkResult walk(const testing::TexturedRoom& room, const core::StereoCamera& camera,
                int right_shift_px, double right_slope = 0.0) {
  auto odometry = StereoOdometry::create(camera, walkOptions());
  EXPECT_TRUE(odometry.ok());
  WalkResult run;
  int k = 0;
  for (const Frame& f : renderWalk(room, right_shift_px, right_slope)) {
    const FrameResult r = odometry->process(f.utime, f.left, f.right);
    run.tracked += r.ok() ? 1 : 0;
    if (!r.calibration_message.empty()) {
      std::printf("frame %d: %s\n", k, r.calibration_message.c_str());
      ++run.decisions;
      run.applied += r.calibration_changed ? 1 : 0;
    }
    ++k;
  }
  run.offset_px = odometry->camera().disparityOffsetPx();
  run.row_slope = odometry->camera().disparityRowSlope();
  return run;
}

// The walk through VoPipeline (the exact rig's calibration), hold_s the start-up hold: what
// each frame released.
std::vector<PipelineOutputs> walkThroughPipeline(const std::vector<Frame>& frames, double hold_s) {
  PipelineOptions options;
  options.odometry = walkOptions();
  options.startup_hold_s = hold_s;
  auto pipeline = VoPipeline::create(options);
  EXPECT_TRUE(pipeline.ok());
  EXPECT_TRUE(pipeline
                  ->handleCalibration(
                      messages::toMsg(testing::rectifiedCalibration(testing::syntheticCamera()), 0))
                  .ok());
  std::vector<PipelineOutputs> released;
  for (const Frame& f : frames) {
    released.push_back(pipeline->handleFrame(
        f.utime, messages::StereoFrame{f.utime, /*rectified=*/true, f.left, f.right}));
  }
  released.push_back(pipeline->flush());
  return released;
}

std::vector<PipelineOutput> all(const std::vector<PipelineOutputs>& released) {
  std::vector<PipelineOutput> out;
  for (const PipelineOutputs& r : released) out.insert(out.end(), r.begin(), r.end());
  return out;
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

TEST(StartupHold, TheFramesBeforeACorrectionAreProcessedAgainWithIt) {
  // The right image 1 px off its calibration: self-calibration corrects the camera within the
  // hold (3 s), and the frames before that come out as if the camera had been right from the
  // first frame on (odometry with that camera, self-calibration off, bit for bit).
  REQUIRE_ROOM(room);
  const std::vector<Frame> frames = renderWalk(room, 1);
  const std::vector<PipelineOutputs> released = walkThroughPipeline(frames, 3.0);
  size_t decision = 0;
  while (decision < frames.size() && released[decision].empty()) ++decision;
  ASSERT_LT(decision, frames.size());
  ASSERT_EQ(released[decision].size(), decision + 1);  // everything held until then
  const std::vector<PipelineOutput> outs = all(released);
  ASSERT_EQ(outs.size(), frames.size());  // nothing lost
  for (size_t i = 0; i < outs.size(); ++i) EXPECT_EQ(outs[i].delta.utime, frames[i].utime);
  const FrameResult& decided = outs[decision].result;
  EXPECT_TRUE(decided.calibration_changed);
  EXPECT_NE(decided.calibration_message.find("processed again"), std::string::npos)
      << decided.calibration_message;
  EXPECT_NEAR(decided.disparity_offset_px, 1.0, 0.15);
  const core::StereoCamera exact = testing::syntheticCamera();
  auto corrected = core::StereoCamera::create(
      exact.fx(), exact.fy(), exact.cx(), exact.cy(), exact.baselineM(), exact.width(),
      exact.height(), outs[0].result.disparity_offset_px, outs[0].result.disparity_row_slope);
  ASSERT_TRUE(corrected.ok());
  OdometryOptions fixed = walkOptions();
  fixed.self_calibrate = false;
  auto reference = StereoOdometry::create(*corrected, fixed);
  ASSERT_TRUE(reference.ok());
  for (size_t i = 0; i <= decision; ++i) {
    const FrameResult r = reference->process(frames[i].utime, frames[i].left, frames[i].right);
    ASSERT_FALSE(i < decision && outs[i].result.calibration_changed) << "frame " << i;
    EXPECT_EQ(outs[i].result.status, r.status) << "frame " << i;
    EXPECT_EQ(outs[i].result.ref_T_cur.matrix(), r.ref_T_cur.matrix()) << "frame " << i;
  }
  // Without the hold the same frames keep the calibration they came with.
  const std::vector<PipelineOutput> unheld = all(walkThroughPipeline(frames, 0.0));
  ASSERT_EQ(unheld.size(), frames.size());
  EXPECT_NE(unheld[decision / 2].result.ref_T_cur.matrix(),
            outs[decision / 2].result.ref_T_cur.matrix());
}

TEST(StartupHold, AnExactRigsFramesAreReleasedAsTheyWereAtTheDecisionOrAfterHoldS) {
  REQUIRE_ROOM(room);
  const std::vector<Frame> frames = renderWalk(room, 0);
  const std::vector<PipelineOutput> unheld = all(walkThroughPipeline(frames, 0.0));
  for (const double hold_s : {3.0, 0.3}) {
    const std::vector<PipelineOutputs> released = walkThroughPipeline(frames, hold_s);
    size_t first = 0;
    while (first < frames.size() && released[first].empty()) ++first;
    ASSERT_LT(first, frames.size()) << hold_s;
    const std::vector<PipelineOutput> outs = all(released);
    ASSERT_EQ(outs.size(), unheld.size());
    for (size_t i = 0; i < outs.size(); ++i) {
      EXPECT_EQ(outs[i].delta.utime, unheld[i].delta.utime);
      EXPECT_EQ(outs[i].result.ref_T_cur.matrix(), unheld[i].result.ref_T_cur.matrix());
      EXPECT_EQ(outs[i].delta.odom_translation[2], unheld[i].delta.odom_translation[2]);
    }
    // Released at the decision (it keeps the calibration) or once the frames span hold_s.
    const bool decided = !outs[first].result.calibration_message.empty();
    const double held_s = 1e-6 * static_cast<double>(frames[first].utime - frames[0].utime);
    EXPECT_TRUE(decided || std::abs(held_s - hold_s) < 1e-9) << hold_s << " " << held_s;
    EXPECT_FALSE(outs[first].result.calibration_changed);
    if (hold_s == 0.3) {
      EXPECT_NEAR(held_s, 0.3, 1e-9);  // before the decision (frame 8)
    }
  }
}

}  // namespace
}  // namespace evermap::vo
