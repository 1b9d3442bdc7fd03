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
#include "core/datasets/euroc.h"
#include "core/datasets/euroc_calibration.h"
#include "core/features/orb_descriptor.h"
#include "core/messages/convert.h"
#include "core/registration/frame_registration.h"
#include "test_data.h"
#include "vo-proc/vo_pipeline.h"
#include "vo-proc/vo_trajectory.h"

namespace evermap::vo {
namespace {

namespace fs = std::filesystem;
using core::SE3d;

core::StereoCalibration eurocCalibration(const fs::path& dir) {
  auto c = datasets::readEurocStereoCalibration(dir / "mav0/cam0/sensor.yaml",
                                                dir / "mav0/cam1/sensor.yaml");
  EXPECT_TRUE(c.ok()) << c.error().message;
  return *c;
}

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
  for (const auto& e : *images) {
    const std::string name = std::to_string(e.t_ns) + ".png";
    const cv::Mat left = cv::imread((dir / "mav0/cam0/data" / name).string(), cv::IMREAD_GRAYSCALE);
    const cv::Mat right = cv::imread((dir / "mav0/cam1/data" / name).string(), cv::IMREAD_GRAYSCALE);
    if (left.empty() || right.empty()) continue;  // cam0/data.csv lists 4 rows without files
    messages::StereoFrame f{messages::utimeFromNs(e.t_ns), false, left, right};
    auto msg = messages::toMsg(f, messages::ImageEncoding::kGray8);
    ASSERT_TRUE(msg.ok());
    const PipelineOutput out = pipeline->handleStereo(*msg);
    const VoStatus expected = frames == 0 ? VoStatus::kNoData : VoStatus::kOk;
    EXPECT_EQ(out.result.status, expected) << "frame " << frames << ": " << out.result.message;
    EXPECT_EQ(out.delta.status, static_cast<int8_t>(expected));
    if (out.keyframe) {
      ++keyframes;
      EXPECT_GT(out.keyframe->num_features, 100);
    }
    if (auto p = chain.add(out.delta)) positions.push_back(p->translation());
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
  std::printf("EuRoC excerpt: %d frames, %d keyframes, net %.4f m, farthest %.4f m, "
              "path %.4f m\n", frames, keyframes, net, farthest, path);
  RecordProperty("path_m", std::to_string(path));
  EXPECT_LT(net, 0.02);
  EXPECT_LT(farthest, 0.02);
  EXPECT_LT(path, 0.02);  // even the summed frame-to-frame jitter stays below 2 cm
  EXPECT_EQ(pipeline->stats().by_status[static_cast<size_t>(VoStatus::kOk)], 94);
}

// The four images of lcd_pairs: their time stamps (SOURCE.txt).
constexpr int64_t kPairStampNs[4] = {1403715386762142976, 1403715288312143104,
                                     1403715400762142976, 1403715400262142976};

struct LoopPairs {
  std::optional<core::StereoRectifier> rectifier;
  std::vector<core::KeyframeFeatures> keyframes;
  std::map<int64_t, SE3d> world_T_body;  // vicon2gt ground truth at the image stamps
};

LoopPairs loadLoopPairs(const fs::path& dir) {
  LoopPairs p;
  auto r = core::StereoRectifier::create(eurocCalibration(dir));
  EXPECT_TRUE(r.ok());
  p.rectifier.emplace(std::move(*r));
  const core::StereoCamera& cam = p.rectifier->camera();
  OdometryOptions o;
  auto extractor = core::StereoFeatureExtractor::create(o.features);
  core::OrbExtractor orb(core::OrbExtractor::Options{});
  for (int i = 0; i < 4; ++i) {
    const fs::path pairs = dir / "lcd_pairs";
    const cv::Mat l = cv::imread((pairs / ("left_img_" + std::to_string(i) + ".png")).string(),
                                 cv::IMREAD_GRAYSCALE);
    const cv::Mat rr = cv::imread((pairs / ("right_img_" + std::to_string(i) + ".png")).string(),
                                  cv::IMREAD_GRAYSCALE);
    auto rect = p.rectifier->rectify(l, rr);
    EXPECT_TRUE(rect.ok()) << rect.error().message;
    core::FeatureFrame frame;
    // As odometry would have seen them: a few frames settle the adaptive FAST threshold.
    for (int k = 0; k < 5; ++k) {
      EXPECT_TRUE(extractor->extract(cam, i, rect->left, rect->right, &frame).ok());
    }
    p.keyframes.push_back(core::makeKeyframeFeatures(frame, orb));
  }
  // OpenVINS' vicon2gt re-processing of the EuRoC ground truth (groundtruth_openvins/
  // V1_01_easy.csv), which has rows at exactly the camera stamps.
  auto gt = datasets::readEurocGroundTruth(dir / "groundtruth_openvins/V1_01_easy.csv",
                                           datasets::PoseFileLayout::kEurocCsv);
  EXPECT_TRUE(gt.ok());
  for (const auto& s : *gt) {
    for (int64_t t : kPairStampNs) {
      if (s.t_ns == t) p.world_T_body[t] = s.world_T_body;
    }
  }
  EXPECT_EQ(p.world_T_body.size(), 4u);
  return p;
}

TEST(RegistrationEuroc, LoopPairsRegisterWithinFiveCentimetresAndOneDegree) {
  EVERMAP_REQUIRE_DATA(dir, "euroc-v101-micro");
  const LoopPairs p = loadLoopPairs(dir);
  ASSERT_EQ(p.keyframes.size(), 4u);
  const core::StereoCamera& cam = p.rectifier->camera();
  // Poses of the rectified left camera: world_T_cam = world_T_body * body_T_rect0.
  const SE3d body_T_cam = p.rectifier->rectifiedCalibration().left.body_T_cam;
  for (const auto& [a, b] : {std::pair{0, 1}, std::pair{2, 3}}) {
    const core::RegistrationSummary s = core::registerFrames(
        cam, p.keyframes[static_cast<size_t>(a)], cam, p.keyframes[static_cast<size_t>(b)],
        core::RegistrationOptions{});
    ASSERT_TRUE(s.ok()) << "pair (" << a << ", " << b << "): " << s.message;
    const SE3d truth = (p.world_T_body.at(kPairStampNs[a]) * body_T_cam).inverse() *
                       (p.world_T_body.at(kPairStampNs[b]) * body_T_cam);
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
    const core::RegistrationSummary s = core::registerFrames(
        cam, p.keyframes[static_cast<size_t>(a)], cam, p.keyframes[static_cast<size_t>(b)],
        core::RegistrationOptions{});
    EXPECT_EQ(s.status, core::RegistrationStatus::kInsufficientInliers)
        << "pair (" << a << ", " << b << "): " << s.message;
  }
}

}  // namespace
}  // namespace evermap::vo
