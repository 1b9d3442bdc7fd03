// Visual odometry on real Kinect frames: the TUM RGB-D freiburg1_rpy excerpt
// (../shared/data/tum-rgbd-fr1-rpy, SOURCE.txt there: 150 frames, 5 s, hand-held rotation up
// to ~50 deg/s) converted by evermap-tum2lcm's code and tracked by evermap-vo-run's, then
// compared with the motion capture as evermap-eval does (SE(3) alignment).
//
// And loop closure's registration (registerFrames, loopclose-proc's options) on the RGB-D
// keyframes VO published, consecutive ones against each other.
//
// Measured when written (docs/results/rgbd.md): 146 of 150 frames tracked, ATE 0.066 m, RPE
// over 30 frames (~1 s) 0.067 m and 2.8 deg; the bounds below left about 1.5x of margin and
// still failed for the 1 px inlier threshold the stereo VO uses (140 tracked, ATE 0.13 m, RPE
// 0.125 m and 3.6 deg), which is why the RGB-D thresholds are 2 px. Since the fast-motion retry
// (2026-11-30): 150 of 150 tracked, ATE 0.080 m, RPE 0.074 m and 3.3 deg; the bound on frames
// is 148, which the run without the retry (146) fails; the ATE bound, 0.10 m, is 1.25x.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include <lcm/lcm-cpp.hpp>

#include "core/messages/channels.h"
#include "core/messages/keyframe_convert.h"
#include "core/registration/frame_registration.h"
#include "log_messages.h"
#include "scratch_dir.h"
#include "test_data.h"
#include "tools/datasets/to_lcm.h"
#include "tools/eval/evaluation.h"
#include "tools/eval/trajectory.h"
#include "tools/vo-run/offline_runner.h"

namespace evermap::vo {
namespace {

constexpr int kFrames = 150;
constexpr int kMinTracked = 148;
constexpr double kMaxAteM = 0.10;
constexpr double kMaxRpe1sM = 0.10;
constexpr double kMaxRpe1sDeg = 4.0;

TEST(VoTumRgbd, ConvertsAndTracksTheExcerptWithinTheStatedBounds) {
  EVERMAP_REQUIRE_DATA(dir, "tum-rgbd-fr1-rpy");
  testing::ScratchDir scratch;
  const auto log = scratch / "tum.lcmlog";
  auto converted = datasets::convertTumRgbdToLcm(dir, log, {});
  ASSERT_TRUE(converted.ok()) << converted.error().message;
  EXPECT_EQ(converted->messages.at(channels::kRgbd), kFrames);
  EXPECT_EQ(converted->skipped_unpaired, 0);
  EXPECT_GT(converted->messages.at(channels::kGroundTruth), 500);
  EXPECT_GT(converted->messages.at(channels::kAccel), 1000);

  auto summary = runOffline(log, OfflineOptions{});
  ASSERT_TRUE(summary.ok()) << summary.error().message;
  std::printf("%s\n", summary->report().c_str());
  EXPECT_EQ(summary->stats.frames, kFrames);
  EXPECT_EQ(summary->stats.by_status[static_cast<size_t>(VoStatus::kBadInput)], 0);
  EXPECT_EQ(summary->stats.calibrations, 1);  // the same camera in every frame
  const int tracked = static_cast<int>(summary->trajectory.size());
  EXPECT_GE(tracked, kMinTracked);

  auto gt = eval::readTum(dir / "groundtruth.txt");
  ASSERT_TRUE(gt.ok()) << gt.error().message;
  eval::EvaluationOptions options;
  options.rpe.delta_frames = 30;  // ~1 s at 30 Hz
  auto report = eval::evaluate(*gt, summary->trajectory, options);
  ASSERT_TRUE(report.ok()) << report.error().message;
  std::printf(
      "TUM fr1_rpy excerpt: %d of %d frames tracked, ATE %.4f m, RPE(30 frames) %.4f m "
      "%.3f deg\n",
      tracked, kFrames, report->ate.translation_m.rmse, report->rpe.translation_m.rmse,
      report->rpe.rotation_deg.rmse);
  RecordProperty("ate_m", std::to_string(report->ate.translation_m.rmse));
  EXPECT_LT(report->ate.translation_m.rmse, kMaxAteM);
  EXPECT_LT(report->rpe.translation_m.rmse, kMaxRpe1sM);
  EXPECT_LT(report->rpe.rotation_deg.rmse, kMaxRpe1sDeg);
}

// The four frames lost at the fastest rotation (up to 170 deg/s) are kept by the fast-motion
// retry (PipelineOptions::rgbd_fast_motion_fraction); without it the run tracks 146 and fails
// the bound above.
TEST(VoTumRgbd, TheFastMotionRetryIsWhatKeepsTheFastestFrames) {
  EVERMAP_REQUIRE_DATA(dir, "tum-rgbd-fr1-rpy");
  testing::ScratchDir scratch;
  const auto log = scratch / "tum.lcmlog";
  auto converted = datasets::convertTumRgbdToLcm(dir, log, {});
  ASSERT_TRUE(converted.ok()) << converted.error().message;
  auto tracked = [&](double fraction, int* retried) {
    OfflineOptions options;
    options.pipeline.rgbd_fast_motion_fraction = fraction;
    auto summary = runOffline(log, options);
    EXPECT_TRUE(summary.ok()) << summary.error().message;
    *retried = 0;
    if (!summary.ok()) return 0;
    for (const FrameStats& f : summary->frames) *retried += f.fast_motion ? 1 : 0;
    return static_cast<int>(summary->trajectory.size());
  };
  int retried_on = 0, retried_off = 0;
  const int on = tracked(PipelineOptions{}.rgbd_fast_motion_fraction, &retried_on);
  const int off = tracked(0.0, &retried_off);
  std::printf("fast-motion retry on: %d tracked (%d retried); off: %d tracked\n", on, retried_on,
              off);
  EXPECT_GE(on, kMinTracked);
  EXPECT_GT(retried_on, 0);
  EXPECT_EQ(retried_off, 0);
  EXPECT_LT(off, kMinTracked);
}

// The Kinect's color camera has a rolling shutter. Its line delay, calibrated from the images
// alone (calibrateLineDelay: the registered pairs' evidence, run again until nothing is left),
// is in the physical range (a readout of 480 rows within the 33 ms frame period: at most 69 us
// per row), and the odometry corrected with it is far more accurate than without it: within issue
// 46's bar (ATE 0.028 m, ORB-SLAM3's on these frames). Measured (docs/results/rgbd.md,
// 2026-12-02): 44.3 +- 5.8 us per row after 7 runs, ATE 0.080 -> 0.019 m, RPE over 30 frames
// 0.025 m and 1.81 deg, 150 of 150 tracked; the RPE bounds are about 1.25x.
// With the motion prior's angular velocities as the evidence's (before) it settled at 28.3 us
// and 0.031 m.
TEST(VoTumRgbd, TheRollingShuttersLineDelayCalibratedFromTheImagesHalvesTheError) {
  EVERMAP_REQUIRE_DATA(dir, "tum-rgbd-fr1-rpy");
  testing::ScratchDir scratch;
  const auto log = scratch / "tum.lcmlog";
  ASSERT_TRUE(datasets::convertTumRgbdToLcm(dir, log, {}).ok());
  auto calibration = calibrateLineDelay(log, OfflineOptions{});
  ASSERT_TRUE(calibration.ok()) << calibration.error().message;
  for (const std::string& line : calibration->runs) std::printf("%s\n", line.c_str());
  EXPECT_GT(calibration->line_delay_us, 33.0);
  EXPECT_LT(calibration->line_delay_us, 69.0);
  EXPECT_GT(calibration->runs.size(), 1u);  // the first run's estimate is not the answer
  const OfflineSummary& summary = calibration->summary;
  EXPECT_EQ(static_cast<int>(summary.trajectory.size()), kFrames);
  auto gt = eval::readTum(dir / "groundtruth.txt");
  ASSERT_TRUE(gt.ok()) << gt.error().message;
  eval::EvaluationOptions options;
  options.rpe.delta_frames = 30;
  auto report = eval::evaluate(*gt, summary.trajectory, options);
  ASSERT_TRUE(report.ok()) << report.error().message;
  std::printf("line delay %.1f us: ATE %.4f m, RPE(30 frames) %.4f m %.3f deg\n",
              calibration->line_delay_us, report->ate.translation_m.rmse,
              report->rpe.translation_m.rmse, report->rpe.rotation_deg.rmse);
  EXPECT_LT(report->ate.translation_m.rmse, 0.028);
  EXPECT_LT(report->rpe.translation_m.rmse, 0.032);
  EXPECT_LT(report->rpe.rotation_deg.rmse, 2.3);
}

// A calibration's later runs judge their pairs with the run before's trajectory, differenced on
// both sides of each frame: a turn about a fixed axis n at the rate c1 + 2 c2 t gives that rate
// at every pose inside (a one-sided difference would be off by c2 dt), one-sided at the ends,
// and in the camera's own frame (the camera starts turned by world_R_0, so the world frame's
// rate, world_R_0 times it, is another vector).
TEST(VoTumRgbd, AngularVelocitiesAreTheTurnOnBothSidesOfEachPose) {
  const core::Vec3 n = core::Vec3(0.3, -1.2, 0.5).normalized();
  const double c1 = 1.0;  // rad/s
  const double c2 = 6.0;  // rad/s^2
  const double dt = 0.033;
  auto theta = [&](double t) { return c1 * t + c2 * t * t; };
  const core::SO3d world_R_0 = core::SO3d::exp(core::Vec3(0.8, 0.0, 1.2));
  ASSERT_GT((world_R_0 * n - n).norm(), 0.5);
  eval::Trajectory trajectory;
  for (int k = 0; k < 5; ++k) {
    trajectory.poses.push_back({static_cast<int64_t>(std::llround(dt * k * 1e9)),
                                core::SE3d(world_R_0 * core::SO3d::exp(theta(dt * k) * n),
                                           core::Vec3(0.1 * k, 0.0, 0.0))});
  }
  const AngularVelocities velocities = angularVelocities(trajectory);
  ASSERT_EQ(velocities.size(), 5u);
  for (int k = 0; k < 5; ++k) {
    const int a = std::max(k - 1, 0);
    const int b = std::min(k + 1, 4);
    const double rate = (theta(dt * b) - theta(dt * a)) / (dt * (b - a));
    if (k > 0 && k < 4) EXPECT_NEAR(rate, c1 + 2.0 * c2 * dt * k, 1e-9);
    const auto it = velocities.find(static_cast<int64_t>(std::llround(dt * k * 1e6)));
    ASSERT_NE(it, velocities.end()) << k;
    EXPECT_LT((it->second - rate * n).norm(), 1e-6) << k;
  }
}

// The nearest ground-truth pose (100 Hz) to `utime`, within 10 ms.
std::optional<core::SE3d> truthAt(const eval::Trajectory& gt, int64_t utime) {
  const eval::StampedPose* best = nullptr;
  for (const auto& p : gt.poses) {
    if (!best || std::llabs(p.t_ns - utime * 1000) < std::llabs(best->t_ns - utime * 1000))
      best = &p;
  }
  if (!best || std::llabs(best->t_ns - utime * 1000) > 10000000) return std::nullopt;
  return best->world_T_body;
}

// What loop closure does with RGB-D keyframes: the KEYFRAME messages (carrying the equivalent
// stereo rig) registered to each other by registerFrames() with loopclose-proc's default
// options, as if revisited, without knowing the camera was a Kinect.
TEST(VoTumRgbd, ConsecutiveKeyframesRegisterAsLoopClosureWouldAgreeingWithMotionCapture) {
  EVERMAP_REQUIRE_DATA(dir, "tum-rgbd-fr1-rpy");
  testing::ScratchDir scratch;
  ASSERT_TRUE(datasets::convertTumRgbdToLcm(dir, scratch / "tum.lcmlog", {}).ok());
  OfflineOptions options;
  options.output_log = scratch / "vo.lcmlog";
  ASSERT_TRUE(runOffline(scratch / "tum.lcmlog", options).ok());
  std::vector<messages::KeyframeMsgContents> keyframes;
  std::vector<int64_t> utimes;
  std::vector<evermap::keyframe_t> msgs;
  ASSERT_NO_FATAL_FAILURE(
      testing::readLogMessages(scratch / "vo.lcmlog", channels::kKeyframe, &msgs));
  for (const evermap::keyframe_t& msg : msgs) {
    auto kf = messages::fromMsg(msg);
    ASSERT_TRUE(kf.ok()) << kf.error().message;
    keyframes.push_back(std::move(*kf));
    utimes.push_back(msg.utime);
  }
  ASSERT_GE(keyframes.size(), 20u);
  auto gt = eval::readTum(dir / "groundtruth.txt");
  ASSERT_TRUE(gt.ok());
  int registered = 0, compared = 0;
  double worst_m = 0.0, worst_deg = 0.0;
  for (size_t i = 0; i + 1 < keyframes.size(); ++i) {
    const auto& a = keyframes[i];
    const auto& b = keyframes[i + 1];
    const core::RegistrationSummary r = core::registerFrames(
        a.camera, a.features, b.camera, b.features, core::RegistrationOptions{});
    if (!r.ok()) continue;
    ++registered;
    const auto wa = truthAt(*gt, utimes[i]);
    const auto wb = truthAt(*gt, utimes[i + 1]);
    if (!wa || !wb) continue;
    ++compared;
    const core::SE3d error = (wa->inverse() * *wb).inverse() * r.a_T_b;
    worst_m = std::max(worst_m, error.translation().norm());
    worst_deg = std::max(worst_deg, core::rotationAngle(error.so3()) * 180.0 / M_PI);
  }
  std::printf(
      "%zu keyframes: %d consecutive pairs registered, %d compared: worst %.4f m %.3f deg\n",
      keyframes.size(), registered, compared, worst_m, worst_deg);
  // Measured when written: 37 keyframes, 31 of 36 pairs registered, worst 3.8 cm and 2.2 deg
  // (the truth is the nearest 100 Hz motion-capture pose, up to 5 ms off at ~50 deg/s).
  const int pairs = static_cast<int>(keyframes.size()) - 1;
  EXPECT_GE(3 * registered, 2 * pairs);
  EXPECT_LT(worst_m, 0.06);
  EXPECT_LT(worst_deg, 3.5);
}

}  // namespace
}  // namespace evermap::vo
