// Visual odometry and frame registration on the real EuRoC V1_01 excerpt
// (../shared/data/euroc-v101-micro, SOURCE.txt there):
//  - the 95 stereo frames: every one tracked, and the estimated motion stays below 2 cm (the
//    vehicle barely moves: 2 mm net, 17 mm of ground-truth path including its jitter);
//  - the 4 loop-closure pairs of lcd_pairs (raw images, rectified here): pairs (0, 1) and
//    (2, 3) register within 5 cm and 1° of the ground truth, the other pairings are refused.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "core/camera/stereo_rectifier.h"
#include "core/features/orb_descriptor.h"
#include "core/messages/convert.h"
#include "core/messages/odometry_frame.h"
#include "core/registration/frame_registration.h"
#include "euroc_loop_pairs.h"
#include "test_data.h"
#include "tools/datasets/euroc.h"
#include "tools/datasets/euroc_calibration.h"
#include "tools/vo-run/vo_trajectory.h"
#include "vo-proc/vo_pipeline.h"

namespace evermap::vo {
namespace {

namespace fs = std::filesystem;
using core::SE3d;

using testing::eurocCalibration;

TEST(VoEuroc, TracksEveryFrameOfTheExcerptAndBarelyMoves) {
  EVERMAP_REQUIRE_DATA(dir, "euroc-v101-micro");
  auto pipeline = VoPipeline::create(PipelineOptions{});
  ASSERT_TRUE(pipeline.ok());
  // Through the messages vo-proc receives: the raw calibration, then raw gray8 pairs.
  ASSERT_TRUE(pipeline->handleCalibration(messages::toMsg(eurocCalibration(dir), 0)).ok());
  auto images = datasets::readEurocImages(dir / "mav0/cam0/data.csv");
  ASSERT_TRUE(images.ok());
  VoTrajectory chain;
  std::vector<core::Vec3> positions;
  int frames = 0, keyframes = 0;
  int64_t first_utime = 0;
  // The outputs, as released (the start-up hold's first frames at its end).
  std::vector<PipelineOutput> outs;
  for (const auto& e : *images) {
    const std::string name = std::to_string(e.t_ns) + ".png";
    const cv::Mat left = cv::imread((dir / "mav0/cam0/data" / name).string(), cv::IMREAD_GRAYSCALE);
    const cv::Mat right =
        cv::imread((dir / "mav0/cam1/data" / name).string(), cv::IMREAD_GRAYSCALE);
    if (left.empty() || right.empty()) continue;  // cam0/data.csv lists 4 rows without files
    messages::StereoFrame f{messages::utimeFromNs(e.t_ns), false, left, right};
    auto msg = messages::toMsg(f, messages::ImageEncoding::kGray8);
    ASSERT_TRUE(msg.ok());
    for (PipelineOutput& out : pipeline->handleStereo(*msg)) outs.push_back(std::move(out));
  }
  for (PipelineOutput& out : pipeline->flush()) outs.push_back(std::move(out));
  for (const PipelineOutput& out : outs) {
    const VoStatus expected = frames == 0 ? VoStatus::kNoData : VoStatus::kOk;
    EXPECT_EQ(out.result.status, expected) << "frame " << frames << ": " << out.result.message;
    EXPECT_EQ(out.delta.status, static_cast<int8_t>(expected));
    if (out.keyframe) {
      ++keyframes;
      EXPECT_GT(out.keyframe->num_features, 100);
    }
    if (auto p = chain.add(out.delta)) {
      positions.push_back(p->translation());
      // The odometry frame (odom_*): one epoch from the first frame, each pose the chain's.
      const auto odom = messages::odometryPose(out.delta);
      ASSERT_TRUE(odom) << "frame " << frames;
      if (frames == 0) first_utime = out.delta.utime;
      EXPECT_EQ(odom->epoch, first_utime);
      EXPECT_LT((odom->odom_T_cam.mean.inverse() * *p).log().norm(), 1e-9) << "frame " << frames;
      if (frames > 0) {
        EXPECT_GT(odom->odom_T_cam.covariance.trace(), 0.0) << "frame " << frames;
      }
    }
    ++frames;
  }
  ASSERT_EQ(frames, 95);
  ASSERT_EQ(positions.size(), 95u);
  double path = 0.0, farthest = 0.0;
  for (size_t i = 1; i < positions.size(); ++i) {
    path += (positions[i] - positions[i - 1]).norm();
    farthest = std::max(farthest, (positions[i] - positions.front()).norm());
  }
  const double net = (positions.back() - positions.front()).norm();
  std::printf(
      "EuRoC excerpt: %d frames, %d keyframes, net %.4f m, farthest %.4f m, "
      "path %.4f m\n",
      frames, keyframes, net, farthest, path);
  RecordProperty("path_m", std::to_string(path));
  EXPECT_LT(net, 0.02);
  EXPECT_LT(farthest, 0.02);
  EXPECT_LT(path, 0.02);  // even the summed frame-to-frame jitter stays below 2 cm
  EXPECT_EQ(pipeline->stats().by_status[static_cast<size_t>(VoStatus::kOk)], 94);
}

TEST(RegistrationEuroc, LoopPairsRegisterWithinFiveCentimetresAndOneDegree) {
  EVERMAP_REQUIRE_DATA(dir, "euroc-v101-micro");
  const testing::LoopPairs p = testing::loadLoopPairs(dir);
  ASSERT_EQ(p.keyframes.size(), 4u);
  const core::StereoCamera& cam = p.rectifier->camera();
  for (const auto& [a, b] : {std::pair{0, 1}, std::pair{2, 3}}) {
    const core::RegistrationSummary s =
        core::registerFrames(cam, p.keyframes[static_cast<size_t>(a)], cam,
                             p.keyframes[static_cast<size_t>(b)], core::RegistrationOptions{});
    ASSERT_TRUE(s.ok()) << "pair (" << a << ", " << b << "): " << s.message;
    const SE3d truth = p.truth(a, b);
    const SE3d err = truth.inverse() * s.a_T_b;
    const double deg = core::rotationAngle(err.so3()) * 180.0 / M_PI;
    std::printf("pair (%d, %d): %s; truth %.3f m %.1f deg; error %.4f m %.3f deg\n", a, b,
                s.message.c_str(), truth.translation().norm(),
                core::rotationAngle(truth.so3()) * 180.0 / M_PI, err.translation().norm(), deg);
    EXPECT_LT(err.translation().norm(), 0.05);
    EXPECT_LT(deg, 1.0);
    // The reported uncertainty covers the error (3 sigma per translation axis).
    for (int k = 0; k < 3; ++k) {
      EXPECT_LT(std::abs(err.translation()(k)), 3.0 * std::sqrt(s.covariance(k, k)) + 0.01);
    }
  }
  // Different places (the two loops, ~3.5 m and 150° apart): refused, not registered wrongly.
  for (const auto& [a, b] : {std::pair{0, 2}, std::pair{1, 3}, std::pair{0, 3}}) {
    const core::RegistrationSummary s =
        core::registerFrames(cam, p.keyframes[static_cast<size_t>(a)], cam,
                             p.keyframes[static_cast<size_t>(b)], core::RegistrationOptions{});
    EXPECT_EQ(s.status, core::RegistrationStatus::kInsufficientInliers)
        << "pair (" << a << ", " << b << "): " << s.message;
  }
}

}  // namespace
}  // namespace evermap::vo
