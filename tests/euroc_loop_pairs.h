#pragma once
// The 4 loop-closure images of EuRoC V1_01 in ../shared/data/euroc-v101-micro/lcd_pairs
// (SOURCE.txt there; pairs (0 match, 1 query) and (2 match, 3 query) are true loop closures),
// turned into keyframes as vo-proc would make them (rectified, stereo features with 3-D points,
// ORB descriptors), with the ground truth at their stamps. Shared by the tests that register
// them directly (vo_euroc_test) and through loopclose-proc (loopclose_euroc_test).
#include <gtest/gtest.h>

#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "core/camera/stereo_rectifier.h"
#include "core/features/orb_descriptor.h"
#include "core/registration/keyframe_features.h"
#include "tools/datasets/euroc.h"
#include "tools/datasets/euroc_calibration.h"
#include "vo-proc/stereo_odometry.h"

namespace evermap::testing {

inline core::StereoCalibration eurocCalibration(const std::filesystem::path& dir) {
  auto c = datasets::readEurocStereoCalibration(dir / "mav0/cam0/sensor.yaml",
                                                dir / "mav0/cam1/sensor.yaml");
  EXPECT_TRUE(c.ok()) << c.error().message;
  return *c;
}

// The four images of lcd_pairs: their time stamps (SOURCE.txt).
inline constexpr int64_t kPairStampNs[4] = {1403715386762142976, 1403715288312143104,
                                            1403715400762142976, 1403715400262142976};

struct LoopPairs {
  std::optional<core::StereoRectifier> rectifier;
  std::vector<core::KeyframeFeatures> keyframes;
  std::map<int64_t, core::SE3d> world_T_body;  // vicon2gt ground truth at the image stamps

  // Ground truth a_T_b between the rectified left cameras of images a and b:
  // world_T_cam = world_T_body * body_T_rect0.
  core::SE3d truth(int a, int b) const {
    const core::SE3d body_T_cam = rectifier->rectifiedCalibration().left.body_T_cam;
    return (world_T_body.at(kPairStampNs[a]) * body_T_cam).inverse() *
           (world_T_body.at(kPairStampNs[b]) * body_T_cam);
  }
};

// Keyframes of raw stereo pairs as odometry would make them: rectified, stereo features,
// ORB descriptors. One extractor for all pairs (its adaptive FAST threshold carries over), and
// a few extractions per pair settle that threshold, as a running odometry would have it.
class KeyframeMaker {
 public:
  explicit KeyframeMaker(const core::StereoRectifier& rectifier)
      : rectifier_(rectifier),
        extractor_(core::StereoFeatureExtractor::create(vo::OdometryOptions{}.features)),
        orb_(core::OrbExtractor::Options{}) {
    EXPECT_TRUE(extractor_.ok());
  }
  core::KeyframeFeatures make(const cv::Mat& left, const cv::Mat& right, int id) {
    auto rect = rectifier_.rectify(left, right);
    EXPECT_TRUE(rect.ok()) << rect.error().message;
    core::FeatureFrame frame;
    for (int k = 0; k < 5; ++k) {
      EXPECT_TRUE(
          extractor_->extract(rectifier_.camera(), id, rect->left, rect->right, &frame).ok());
    }
    return core::makeKeyframeFeatures(frame, orb_);
  }

 private:
  const core::StereoRectifier& rectifier_;
  decltype(core::StereoFeatureExtractor::create(vo::OdometryOptions{}.features)) extractor_;
  core::OrbExtractor orb_;
};

inline LoopPairs loadLoopPairs(const std::filesystem::path& dir) {
  LoopPairs p;
  auto r = core::StereoRectifier::create(eurocCalibration(dir));
  EXPECT_TRUE(r.ok());
  p.rectifier.emplace(std::move(*r));
  KeyframeMaker maker(*p.rectifier);
  for (int i = 0; i < 4; ++i) {
    const std::filesystem::path pairs = dir / "lcd_pairs";
    const cv::Mat l = cv::imread((pairs / ("left_img_" + std::to_string(i) + ".png")).string(),
                                 cv::IMREAD_GRAYSCALE);
    const cv::Mat rr = cv::imread((pairs / ("right_img_" + std::to_string(i) + ".png")).string(),
                                  cv::IMREAD_GRAYSCALE);
    p.keyframes.push_back(maker.make(l, rr, i));
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

}  // namespace evermap::testing
