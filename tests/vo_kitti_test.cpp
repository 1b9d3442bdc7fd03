// vo-proc StereoOdometry on real KITTI stereo with large inter-frame motion (issue 16): the
// kitti-stereo-clip data set, 51 rectified pairs about 1 m apart (a car at 10 m/s, 10 Hz)
// through a turn, read straight from its folder (tools/vo-run/sequence_run.h).
#include <gtest/gtest.h>

#include <cstdio>
#include <optional>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "core/features/orb_descriptor.h"
#include "core/features/stereo_features.h"
#include "core/messages/odometry_frame.h"
#include "scratch_dir.h"
#include "test_data.h"
#include "tools/datasets/to_lcm.h"
#include "tools/datasets/kitti.h"
#include "core/registration/disparity_offset.h"
#include "tools/vo-run/offline_runner.h"
#include "tools/vo-run/sequence_run.h"
#include "tools/vo-run/vo_trajectory.h"
#include "vo-proc/vo_pipeline.h"

namespace evermap::vo {
namespace {

// The odometry with the calibration held as given (self-calibration off): what these tests
// measure; the clip with self-calibration is the last test.
SequenceRunOptions clipOptions() {
  SequenceRunOptions o;
  o.sequence.rate_hz = 10.0;  // the clip has no times.txt; KITTI records at about 10 Hz
  o.odometry.self_calibrate = false;
  return o;
}

// The offline runner's options with the calibration held as given.
OfflineOptions fixedCalibration() {
  OfflineOptions o;
  o.pipeline.odometry.self_calibrate = false;
  return o;
}

// With calib.txt as it is, the chained path is 7.6 % longer than the ground truth's, as FOVIS's
// is 11 % (issue 16): the clip's images carry a disparity offset of about +0.8 px against
// calib.txt (next test; docs/vo.md "The KITTI clip's calibration"). What is asserted here, with
// calib.txt as given: every frame registered, inliers of FOVIS's order, rotation within 2 deg,
// translation within FOVIS's 10 % on the same frames.
TEST(VoKitti, TracksEveryFrameOfTheStereoClipWithFovisInliersAndRotationWithinTwoDegrees) {
  EVERMAP_REQUIRE_DATA(dir, "kitti-stereo-clip");
  const auto run = runKittiSequence(dir, clipOptions());
  ASSERT_TRUE(run.ok()) << run.error().message;
  std::printf("%s\n", run->report().c_str());
  int tracked = 0;
  for (size_t k = 0; k < run->frames.size(); ++k) {
    const FrameResult& f = run->frames[k];
    const bool registered = f.ok() && !f.bridged;
    if (registered || (k == 0 && f.status == VoStatus::kNoData)) {
      ++tracked;
    } else {
      ADD_FAILURE() << "frame " << k << ": " << (f.bridged ? "bridged" : toString(f.status)) << ": "
                    << f.message;
    }
  }
  EXPECT_EQ(run->frames.size(), 51u);
  EXPECT_EQ(tracked, 51);
  EXPECT_GT(run->path_length_m, 45.0);  // 51.8 m along the ground truth
  EXPECT_LE(run->end_rotation_deg, 2.0);
  EXPECT_LE(run->end_error_percent, 10.0);
  // Inliers of FOVIS's order (164 per frame on this clip; 26.6 before issue 16).
  EXPECT_GE(run->mean_inliers, 100.0);
}

// The odometry frame vo-proc stamps on its VO_DELTA messages (issue 17), on a real drive of
// 52 m with a turn: one epoch from the first frame, every frame's pose the keyframe chain's
// (what evermap-vo-run chains from the deltas), and the motion between two frames far apart
// with the covariance of the increments between them, compounded one by one.
TEST(VoKitti, TheOdometryFrameOfTheClipIsItsKeyframeChain) {
  EVERMAP_REQUIRE_DATA(dir, "kitti-stereo-clip");
  const auto run = runKittiSequence(dir, clipOptions());
  ASSERT_TRUE(run.ok()) << run.error().message;
  messages::OdometryFrame odom;
  VoTrajectory chain;
  std::vector<messages::OdometryPose> poses;
  std::vector<evermap::vo_delta_t> deltas;
  for (const FrameResult& f : run->frames) {
    evermap::vo_delta_t m = toMsg(f);
    odom.stamp(m);
    const auto chained = chain.add(m);
    const auto pose = messages::odometryPose(m);
    ASSERT_EQ(chained.has_value(), pose.has_value()) << "frame " << f.utime;
    if (!pose) continue;
    EXPECT_EQ(pose->epoch, run->frames.front().utime);
    EXPECT_LT((pose->odom_T_cam.mean.inverse() * *chained).log().norm(), 1e-9);
    poses.push_back(*pose);
    deltas.push_back(m);
  }
  ASSERT_EQ(poses.size(), 51u);
  // From a keyframe near the start to the last frame: the increments between, one by one.
  size_t a = 0;
  for (size_t k = 1; k < deltas.size() && a == 0; ++k)
    if (deltas[k].keyframe_changed && deltas[k].status == evermap::vo_delta_t::STATUS_OK) a = k;
  ASSERT_GT(a, 0u);
  core::UncertainPose expected;
  for (size_t k = a + 1; k < deltas.size(); ++k) {
    if (!deltas[k].keyframe_changed && k + 1 != deltas.size()) continue;
    core::Mat6 c;
    for (int r = 0; r < 6; ++r)
      for (int j = 0; j < 6; ++j) c(r, j) = deltas[k].covariance[6 * r + j];
    const Eigen::Quaterniond q(deltas[k].orientation[0], deltas[k].orientation[1],
                               deltas[k].orientation[2], deltas[k].orientation[3]);
    const core::Vec3 t(deltas[k].translation[0], deltas[k].translation[1],
                       deltas[k].translation[2]);
    expected = core::compound(expected, core::UncertainPose{core::SE3d(q, t), c});
  }
  const auto between = messages::odometryBetween(poses[a], core::Mat6::Zero(), poses.back());
  ASSERT_TRUE(between) << between.error().message;
  EXPECT_GT(between->mean.translation().norm(), 40.0);
  EXPECT_LT((between->mean.inverse() * expected.mean).log().norm(), 1e-9);
  EXPECT_LT((between->covariance - expected.covariance).norm(), 1e-6 * expected.covariance.norm());
}

// The clip's disparity offset from its own images (consecutive frames registered by ORB, no
// ground truth; core/registration/disparity_offset.h), then odometry with it: issue 16's bar.
TEST(VoKitti, WithTheDisparityOffsetOfItsOwnImagesTheClipDriftsLessThanTwoPercent) {
  EVERMAP_REQUIRE_DATA(dir, "kitti-stereo-clip");
  const auto seq = datasets::readKittiSequence(dir, clipOptions().sequence);
  ASSERT_TRUE(seq.ok()) << seq.error().message;
  const auto& P = seq->projections;
  auto extractor = core::StereoFeatureExtractor::create(core::StereoFeatureExtractor::Options{});
  ASSERT_TRUE(extractor.ok());
  core::OrbExtractor orb{core::OrbExtractor::Options{}};
  std::vector<core::StereoMatchPair> pairs;
  core::KeyframeFeatures previous;
  std::optional<core::StereoCamera> camera;
  for (size_t k = 0; k < seq->frames.size(); ++k) {
    const cv::Mat left = cv::imread(seq->leftImage(seq->frames[k]).string(), cv::IMREAD_GRAYSCALE);
    const cv::Mat right =
        cv::imread(seq->rightImage(seq->frames[k]).string(), cv::IMREAD_GRAYSCALE);
    if (!camera) {
      camera = *core::StereoCamera::create(P.P0(0, 0), P.P0(1, 1), P.P0(0, 2), P.P0(1, 2),
                                           -P.P1(0, 3) / P.P1(0, 0), left.cols, left.rows);
    }
    core::FeatureFrame frame;
    ASSERT_TRUE(extractor->extract(*camera, static_cast<int64_t>(k), left, right, &frame).ok());
    core::KeyframeFeatures kf = core::makeKeyframeFeatures(frame, orb);
    if (k > 0) {
      pairs.push_back(core::matchPair(
          previous, kf,
          core::registerFrames(*camera, previous, *camera, kf, core::RegistrationOptions{})));
    }
    previous = std::move(kf);
  }
  const auto offset = core::estimateDisparityOffset(*camera, pairs, core::DisparityOffsetOptions{});
  ASSERT_TRUE(offset.ok()) << offset.error().message;
  std::printf("%s\n", offset->message.c_str());
  EXPECT_GT(offset->pairs, 35);
  EXPECT_NEAR(offset->offset_px, 0.8, 0.2);  // calib.txt as given: 0 would be consistent

  // The offset becomes the calibration's (right cx = left cx + offset), as
  // evermap-kitti2lcm --disparity-offset writes it into STEREO_CALIB.
  SequenceRunOptions o = clipOptions();
  o.disparity_offset_px = offset->offset_px;
  const auto run = runKittiSequence(dir, o);
  ASSERT_TRUE(run.ok()) << run.error().message;
  std::printf("%s\n", run->report().c_str());
  int failed = 0;
  for (const FrameResult& f : run->frames) failed += !f.ok() || f.bridged;
  EXPECT_EQ(failed, 1);  // the first frame (no data)
  EXPECT_LE(run->end_error_percent, 2.0);
  EXPECT_LE(run->end_rotation_deg, 2.0);
}

// The path a user takes through the pipeline (issue 16): evermap-kitti2lcm --disparity-offset
// 0.8 writes the offset into STEREO_CALIB (the right camera's cx), and the offline runner
// (vo-proc's VoPipeline) corrects the clip with no option of its own: the same poses as the folder
// run with that calibration, and the same as evermap-vo-run --disparity-offset 0.8 over a log
// without it.
TEST(VoKitti, ALogWhoseCalibrationCarriesTheDisparityOffsetIsCorrectedWithoutAnOption) {
  EVERMAP_REQUIRE_DATA(dir, "kitti-stereo-clip");
  const testing::ScratchDir scratch;
  datasets::KittiToLcmOptions convert;
  convert.encoding = messages::ImageEncoding::kGray8;
  convert.sequence.rate_hz = 10.0;
  const auto plain_log = scratch.path() / "clip.lcmlog";
  ASSERT_TRUE(datasets::convertKittiToLcm(dir, plain_log, convert).ok());
  convert.disparity_offset_px = 0.8;
  const auto offset_log = scratch.path() / "clip_offset.lcmlog";
  const auto converted = datasets::convertKittiToLcm(dir, offset_log, convert);
  ASSERT_TRUE(converted.ok()) << converted.error().message;

  const auto corrected = runOffline(offset_log, fixedCalibration());
  ASSERT_TRUE(corrected.ok()) << corrected.error().message;
  OfflineOptions override_offset = fixedCalibration();
  override_offset.disparity_offset_px = 0.8;
  const auto overridden = runOffline(plain_log, override_offset);
  ASSERT_TRUE(overridden.ok()) << overridden.error().message;
  override_offset.disparity_offset_px = 0.0;  // the override also takes an offset away
  const auto uncorrected = runOffline(offset_log, override_offset);
  ASSERT_TRUE(uncorrected.ok()) << uncorrected.error().message;
  const auto as_given = runOffline(plain_log, fixedCalibration());
  ASSERT_TRUE(as_given.ok()) << as_given.error().message;

  SequenceRunOptions o = clipOptions();
  o.disparity_offset_px = 0.8;
  const auto folder = runKittiSequence(dir, o);
  ASSERT_TRUE(folder.ok()) << folder.error().message;
  std::printf("folder run with the offset in calib: %s\n", folder->report().c_str());

  // End error against the ground truth of the last frame (both start at the identity).
  auto endErrorPercent = [&](const OfflineSummary& s) {
    EXPECT_EQ(s.trajectory.size(), folder->gt.size());
    const core::SE3d& est = s.trajectory.poses.back().world_T_body;
    return 100.0 * (est.translation() - folder->gt.back().translation()).norm() /
           folder->path_length_m;
  };
  const double e_corrected = endErrorPercent(*corrected);
  std::printf(
      "end error: log with the offset %.2f %%, override of a plain log %.2f %%, "
      "offset taken away %.2f %%, plain log %.2f %%\n",
      e_corrected, endErrorPercent(*overridden), endErrorPercent(*uncorrected),
      endErrorPercent(*as_given));
  EXPECT_LE(e_corrected, 2.0);
  EXPECT_NEAR(e_corrected, folder->end_error_percent, 0.01);
  EXPECT_GT(endErrorPercent(*as_given), 5.0);
  // The override and the calibration are one path: the same poses to the bit.
  for (const auto& [a, b] :
       {std::pair{&*corrected, &*overridden}, std::pair{&*as_given, &*uncorrected}}) {
    ASSERT_EQ(a->trajectory.size(), b->trajectory.size());
    for (size_t i = 0; i < a->trajectory.size(); ++i) {
      EXPECT_EQ(a->trajectory.poses[i].world_T_body.matrix(),
                b->trajectory.poses[i].world_T_body.matrix())
          << "pose " << i;
    }
  }
}

TEST(VoKitti, WithoutTheMotionPriorAndTheDepthAwareCliqueFewerMatchesAreConsistent) {
  // What the two changes of issue 16 buy, measured on the same frames: with FOVIS's
  // rotation-only prediction and the fixed 0.1 m clique threshold (the options before),
  // far fewer inliers per frame.
  EVERMAP_REQUIRE_DATA(dir, "kitti-stereo-clip");
  SequenceRunOptions before = clipOptions();
  before.odometry.constant_velocity = false;
  before.odometry.registration.disparity_sigma_px = 0.0;
  before.max_frames = 20;
  SequenceRunOptions now = clipOptions();
  now.max_frames = 20;
  const auto a = runKittiSequence(dir, before);
  const auto b = runKittiSequence(dir, now);
  ASSERT_TRUE(a.ok()) << a.error().message;
  ASSERT_TRUE(b.ok()) << b.error().message;
  std::printf("before: %.1f inliers per frame; now: %.1f\n", a->mean_inliers, b->mean_inliers);
  EXPECT_GT(b->mean_inliers, 2.0 * a->mean_inliers);
}

// Issue 46: the clip as given (calib.txt, no option), its disparity offset and row slope found
// online from its own images by the odometry's self-calibration: the first correction applied
// within the first 2 s, the end error about a third of the 7.7 % without (2.69 % measured; 3.42 %
// with the offset alone; issue 46's bar of 1.5 %, reached with the first correction from the
// first frame, is not met: the frames before it carry the scale error).
TEST(VoKitti, TheClipAsGivenCalibratesItselfOnlineWithinTwoSecondsAndMeetsTheBarFromItsFirstFrame) {
  EVERMAP_REQUIRE_DATA(dir, "kitti-stereo-clip");
  SequenceRunOptions o = clipOptions();
  o.odometry.self_calibrate = true;
  const auto run = runKittiSequence(dir, o);
  ASSERT_TRUE(run.ok()) << run.error().message;
  int first_applied = -1;
  for (size_t k = 0; k < run->frames.size(); ++k) {
    const FrameResult& f = run->frames[k];
    if (!f.calibration_message.empty())
      std::printf("frame %zu: %s\n", k, f.calibration_message.c_str());
    if (f.calibration_changed && first_applied < 0) first_applied = static_cast<int>(k);
  }
  const double offset = run->frames.back().disparity_offset_px;
  const double slope = run->frames.back().disparity_row_slope;
  std::printf("%s\nfirst applied at frame %d, offset at the end %+.3f px, row slope %+.5f\n",
              run->report().c_str(), first_applied, offset, slope);
  EXPECT_GE(first_applied, 1);
  EXPECT_LE(first_applied, 20);
  EXPECT_GT(offset, 1.0);  // at row cy; the offset alone said +0.8-1.2 px
  EXPECT_LT(offset, 2.0);
  EXPECT_GT(slope, 0.003);  // the images' fit over the whole clip: +0.0038 px per row
  EXPECT_LT(slope, 0.008);
  // The frames before the decision were held and processed again with it (vo_pipeline.h):
  // issue 46's bar. Without the hold they keep the calibration they came with.
  EXPECT_LE(run->end_error_percent, 1.5);
  EXPECT_LE(run->ate_rmse_m, 0.25);
  EXPECT_LE(run->end_rotation_deg, 2.0);
  o.startup_hold_s = 0.0;
  const auto unheld = runKittiSequence(dir, o);
  ASSERT_TRUE(unheld.ok()) << unheld.error().message;
  std::printf("without the start-up hold: %s\n", unheld->report().c_str());
  EXPECT_GT(unheld->end_error_percent, run->end_error_percent + 1.0);
}

TEST(VoKitti, AFolderWithoutImagesOrTimesIsAnErrorNotACrash) {
  SequenceRunOptions o;
  const auto missing = runKittiSequence("/nonexistent/clip", o);
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().message.find("/nonexistent/clip/image_0: no left images"),
            std::string::npos)
      << missing.error().message;
  EVERMAP_REQUIRE_DATA(dir, "kitti-stereo-clip");
  const auto no_rate = runKittiSequence(dir, o);
  ASSERT_FALSE(no_rate.ok());
  EXPECT_NE(no_rate.error().message.find("times.txt: no such file"), std::string::npos)
      << no_rate.error().message;
}

}  // namespace
}  // namespace evermap::vo
