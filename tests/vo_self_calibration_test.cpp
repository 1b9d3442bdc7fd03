// The stereo self-calibration of vo-proc (VoPipeline, disparity_offset.*) on synthetic stereo of
// a textured room (tests/vo_synthetic.h), the camera moving forward: a right image one pixel
// off its calibration (a disparity offset of +1 px) is found within the first frames and
// applied; an exact rig is left as it is; a given offset (the estimate off) is never touched.
#include <gtest/gtest.h>

#include <cstdio>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "core/messages/convert.h"
#include "core/registration/disparity_offset.h"
#include "test_data.h"
#include "vo-proc/vo_pipeline.h"
#include "vo_synthetic.h"

namespace evermap::vo {
namespace {

using core::SE3d;
using core::SO3d;
using core::Vec3;

struct ForwardRun {
  std::vector<std::string> notes;
  int tracked = 0;
};

// `frames` frames 0.1 m apart, forward through the room and turning slightly, at 20 Hz; the
// right image moved right by `right_shift_px` whole pixels.
ForwardRun runForward(VoPipeline& pipeline, const testing::TexturedRoom& room, int right_shift_px,
                      int frames) {
  const core::StereoCamera camera = testing::syntheticCamera();
  EXPECT_TRUE(
      pipeline.handleCalibration(messages::toMsg(testing::rectifiedCalibration(camera), 0)).ok());
  cv::RNG rng(11);
  ForwardRun run;
  for (int k = 0; k < frames; ++k) {
    const SE3d world_T_cam(SO3d::exp(Vec3(0.0, 0.01 * k, 0.0)),
                           Vec3(0.03 * k, 0.1, -2.8 + 0.1 * k));
    cv::Mat left, right;
    room.render(camera, world_T_cam, &left, &right, &rng);
    right = testing::shiftedRight(right, right_shift_px);
    const int64_t utime = 1000000 + 50000 * k;
    const PipelineOutput out =
        pipeline.handleFrame(utime, messages::StereoFrame{utime, true, left, right});
    if (!out.note.empty()) {
      std::printf("frame %d: %s\n", k, out.note.c_str());
      run.notes.push_back(out.note);
    }
    if (out.result.ok()) ++run.tracked;
  }
  return run;
}

#define REQUIRE_ROOM(room)                                                          \
  const testing::TexturedRoom room(testing::dataRoot());                            \
  if (!room.ok()) {                                                                 \
    if (testing::underCi()) FAIL() << "room textures not found";                    \
    GTEST_SKIP() << "room textures (kitti07-mono-160, euroc-v101-micro) not found"; \
  }

TEST(VoSelfCalibration, ARightImageOnePixelOffIsFoundWithinTheFirstSecondAndApplied) {
  REQUIRE_ROOM(room);
  auto pipeline = VoPipeline::create(PipelineOptions{});
  ASSERT_TRUE(pipeline.ok());
  const ForwardRun run = runForward(*pipeline, room, 1, 30);
  EXPECT_EQ(run.tracked, 29);
  ASSERT_TRUE(pipeline->offsetSettled());
  EXPECT_LE(pipeline->offsetConvergedAfterSeconds(), 1.0);
  EXPECT_NEAR(pipeline->offsetAppliedPx(), 1.0, 0.2);
  EXPECT_NEAR(pipeline->camera().disparityOffsetPx(), pipeline->offsetAppliedPx(), 1e-12);
  ASSERT_FALSE(run.notes.empty());
  EXPECT_NE(run.notes.front().find("applied"), std::string::npos) << run.notes.front();
}

TEST(VoSelfCalibration, AnExactRigIsLeftAsCalibrated) {
  REQUIRE_ROOM(room);
  auto pipeline = VoPipeline::create(PipelineOptions{});
  ASSERT_TRUE(pipeline.ok());
  const ForwardRun run = runForward(*pipeline, room, 0, 30);
  EXPECT_EQ(run.tracked, 29);
  ASSERT_TRUE(pipeline->offsetSettled());
  EXPECT_EQ(pipeline->offsetRounds(), 1);
  EXPECT_EQ(pipeline->offsetAppliedPx(), 0.0);
  EXPECT_EQ(pipeline->camera().disparityOffsetPx(), 0.0);
  const auto& estimate = pipeline->disparityOffset();
  ASSERT_TRUE(estimate.has_value());
  EXPECT_TRUE(estimate->converged());
  EXPECT_FALSE(estimate->significant());
  EXPECT_LE(std::abs(estimate->offsetPx()), 3.0 * estimate->sigmaPx()) << estimate->describe();
  ASSERT_EQ(run.notes.size(), 1u);
  EXPECT_NE(run.notes.front().find("not applied"), std::string::npos) << run.notes.front();
}

TEST(VoSelfCalibration, WithTheEstimateOffTheCalibrationIsNeverChanged) {
  REQUIRE_ROOM(room);
  PipelineOptions options;
  options.disparity_offset.estimate = false;
  auto pipeline = VoPipeline::create(options);
  ASSERT_TRUE(pipeline.ok());
  const ForwardRun run = runForward(*pipeline, room, 1, 15);
  EXPECT_TRUE(run.notes.empty());
  EXPECT_FALSE(pipeline->disparityOffset().has_value());
  EXPECT_EQ(pipeline->camera().disparityOffsetPx(), 0.0);
}

TEST(VoSelfCalibration, RefusesOptionsOutOfRange) {
  PipelineOptions options;
  options.disparity_offset.max_rounds = 0;
  EXPECT_FALSE(VoPipeline::create(options).ok());
  options = PipelineOptions{};
  options.disparity_offset.tracker.converged_sigma_px = 0.0;
  EXPECT_FALSE(VoPipeline::create(options).ok());
  options = PipelineOptions{};
  options.disparity_offset.tracker.min_pairs = 1;
  EXPECT_FALSE(VoPipeline::create(options).ok());
}

}  // namespace
}  // namespace evermap::vo
