// core/features: pyramid, FAST with adaptive threshold and bucketing, patch descriptors,
// Lucas-Kanade patch alignment, sub-pixel stereo depth and ORB descriptors at given corners.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/features/fast_detector.h"
#include "core/features/image_pyramid.h"
#include "core/features/orb_descriptor.h"
#include "core/features/patch_alignment.h"
#include "core/features/patch_descriptor.h"
#include "core/features/stereo_depth.h"
#include "core/features/stereo_features.h"
#include "test_data.h"
#include "vo_synthetic.h"

namespace evermap::core {
namespace {

// A textured image without the data set: smoothed noise (corners everywhere).
cv::Mat texture(int width, int height, uint64_t seed) {
  cv::Mat noise(height, width, CV_8UC1);
  cv::RNG rng(seed);
  rng.fill(noise, cv::RNG::UNIFORM, 0, 256);
  cv::Mat smooth;
  cv::GaussianBlur(noise, smooth, cv::Size(0, 0), 1.5);
  cv::normalize(smooth, smooth, 0, 255, cv::NORM_MINMAX);
  return smooth;
}

// The first EuRoC image when present, else a synthetic texture.
cv::Mat realOrSynthetic() {
  const auto dir = testing::dataDir("euroc-v101-micro");
  if (!dir.empty()) {
    cv::Mat m =
        cv::imread((dir / "mav0/cam0/data/1403715273262142976.png").string(), cv::IMREAD_GRAYSCALE);
    if (!m.empty()) return m;
  }
  return texture(752, 480, 1);
}

TEST(ImagePyramid, LevelsHalveTheSizeAndShareTheOrigin) {
  cv::Mat image(480, 752, CV_8UC1, cv::Scalar(0));
  cv::circle(image, cv::Point(200, 100), 3, cv::Scalar(255), -1);
  ImagePyramid p;
  ASSERT_TRUE(p.build(image, 4).ok());
  ASSERT_EQ(p.numLevels(), 4);
  EXPECT_EQ(p.level(1).size(), cv::Size(376, 240));
  EXPECT_EQ(p.level(3).size(), cv::Size(94, 60));
  // The blob at (200, 100) of level 0 is brightest at (100, 50) of level 1, (50, 25) of 2.
  for (int l = 1; l <= 2; ++l) {
    cv::Point at;
    cv::minMaxLoc(p.level(l), nullptr, nullptr, nullptr, &at);
    EXPECT_EQ(at, cv::Point(200 >> l, 100 >> l)) << "level " << l;
  }
}

TEST(ImagePyramid, RefusesBadImagesAndCopiesDeeply) {
  ImagePyramid p;
  EXPECT_FALSE(p.build(cv::Mat(), 3).ok());
  EXPECT_FALSE(p.build(cv::Mat(480, 752, CV_8UC3), 3).ok());
  EXPECT_FALSE(p.build(cv::Mat(20, 20, CV_8UC1), 3).ok());
  EXPECT_FALSE(p.build(cv::Mat(480, 752, CV_8UC1), 0).ok());
  cv::Mat image = texture(160, 120, 2);
  ASSERT_TRUE(p.build(image, 2).ok());
  // The pyramid does not alias the caller's image, and a copy does not alias the pyramid.
  const ImagePyramid copy = p;
  image.setTo(0);
  EXPECT_GT(cv::norm(p.level(0)), 0.0);
  ASSERT_TRUE(p.build(cv::Mat(120, 160, CV_8UC1, cv::Scalar(7)), 2).ok());
  EXPECT_NE(copy.level(0).at<uint8_t>(60, 80), 7);
}

TEST(FastDetector, BucketsHoldAtMostTheirShareAndCornersAvoidTheBorder) {
  ImagePyramid p;
  ASSERT_TRUE(p.build(realOrSynthetic(), 3).ok());
  FastDetector::Options o;
  o.initial_threshold = o.min_threshold = 6;  // many corners
  o.max_per_bucket = 4;
  FastDetector fast(o);
  const std::vector<Keypoint> k = fast.detect(p, 3);
  ASSERT_GT(k.size(), 100u);
  std::map<std::tuple<int, int, int>, int> count;
  for (const Keypoint& c : k) {
    const cv::Mat& level = p.level(c.level);
    EXPECT_GE(c.u, o.border_px);
    EXPECT_GE(c.v, o.border_px);
    EXPECT_LT(c.u, level.cols - o.border_px);
    EXPECT_LT(c.v, level.rows - o.border_px);
    ++count[{c.level, static_cast<int>(c.u) / o.bucket_width_px,
             static_cast<int>(c.v) / o.bucket_height_px}];
  }
  for (const auto& [bucket, n] : count) EXPECT_LE(n, o.max_per_bucket);
  // Strongest first within a level.
  for (size_t i = 1; i < k.size(); ++i) {
    if (k[i].level == k[i - 1].level) {
      EXPECT_LE(k[i].score, k[i - 1].score);
    }
  }
}

TEST(FastDetector, AdaptiveThresholdRisesOnRichImagesAndFallsOnBlankOnes) {
  ImagePyramid rich, blank;
  ASSERT_TRUE(rich.build(texture(752, 480, 3), 3).ok());
  ASSERT_TRUE(blank.build(cv::Mat(480, 752, CV_8UC1, cv::Scalar(90)), 3).ok());
  FastDetector::Options o;
  o.target_pixels_per_feature = 2000;  // ~180 corners wanted: the texture has many more
  FastDetector fast(o);
  const int start = fast.threshold();
  for (int i = 0; i < 20; ++i) fast.detect(rich, 3);
  EXPECT_GT(fast.threshold(), start);
  for (int i = 0; i < 200; ++i) fast.detect(blank, 3);
  EXPECT_EQ(fast.threshold(), o.min_threshold);
  EXPECT_TRUE(fast.detect(blank, 3).empty());
  FastDetector::Options bad;
  bad.min_threshold = 50;
  bad.max_threshold = 20;
  EXPECT_FALSE(bad.validate().ok());
}

TEST(PatchDescriptor, IgnoresABrightnessOffset) {
  const cv::Mat a = texture(64, 64, 4);
  cv::Mat b;
  a.convertTo(b, CV_8U, 0.8, 20.0);  // darker contrast plus an offset
  const PatchDescriptor da = patchDescriptor(a, 30, 30);
  EXPECT_EQ(patchSad(da, da), 0);
  // Only the contrast change is left (the offset is removed by the mean).
  EXPECT_LT(patchSad(da, patchDescriptor(b, 30, 30)), patchSad(da, patchDescriptor(a, 31, 30)));
}

TEST(PatchAlignment, RecoversASubPixelShift) {
  const cv::Mat a = texture(200, 200, 5);
  // b(x) = a(x - s): the content moves by s.
  const Eigen::Vector2f s(0.37f, -0.81f);
  cv::Mat b;
  const cv::Mat M = (cv::Mat_<double>(2, 3) << 1, 0, -s.x(), 0, 1, -s.y());
  cv::warpAffine(a, b, M, a.size(), cv::INTER_CUBIC | cv::WARP_INVERSE_MAP);
  PatchAlignmentOptions o;
  std::vector<float> err;
  for (int v = 40; v <= 160; v += 20) {
    for (int u = 40; u <= 160; u += 20) {
      const auto p = alignPatch(a, u, v, b, Eigen::Vector2f(u, v), o);
      ASSERT_TRUE(p.has_value());
      err.push_back((*p - Eigen::Vector2f(u, v) - s).norm());
    }
  }
  std::sort(err.begin(), err.end());
  EXPECT_LT(err[err.size() / 2], 0.1f);  // the integer search alone is off by up to 0.7 px
  // No texture, no position.
  const cv::Mat flat(100, 100, CV_8UC1, cv::Scalar(50));
  EXPECT_FALSE(alignPatch(flat, 50, 50, flat, Eigen::Vector2f(50, 50), o).has_value());
}

// A rectified camera of `image`'s size (its intrinsics do not matter to the matching), with the
// given disparity offset (cx_right - cx_left).
StereoCamera cameraOf(const cv::Mat& image, double disparity_offset_px = 0.0) {
  return *StereoCamera::create(400.0, 400.0, image.cols / 2.0, image.rows / 2.0, 0.1, image.cols,
                               image.rows, disparity_offset_px);
}

TEST(StereoDepth, RecoversTheSubPixelDisparityOfAShiftedImage) {
  const cv::Mat left = texture(400, 200, 6);
  const double d = 11.3;
  // right(x) = left(x + d): a point at u in the left image is at u - d in the right one.
  cv::Mat right;
  const cv::Mat M = (cv::Mat_<double>(2, 3) << 1, 0, d, 0, 1, 0);
  cv::warpAffine(left, right, M, left.size(), cv::INTER_CUBIC | cv::WARP_INVERSE_MAP);
  ImagePyramid pl, pr;
  ASSERT_TRUE(pl.build(left, 2).ok());
  ASSERT_TRUE(pr.build(right, 2).ok());
  StereoDepth depth(StereoDepth::Options{});
  std::vector<float> err;
  for (int l = 0; l < 2; ++l) {
    for (int v = 20; v < pl.level(l).rows - 20; v += 15) {
      for (int u = 60; u < pl.level(l).cols - 20; u += 15) {
        const float got =
            depth.disparity(cameraOf(left), pl, pr, Keypoint{float(u), float(v), 0, int8_t(l)});
        if (std::isfinite(got)) err.push_back(std::abs(got - static_cast<float>(d)));
      }
    }
  }
  ASSERT_GT(err.size(), 100u);
  std::sort(err.begin(), err.end());
  EXPECT_LT(err[err.size() / 2], 0.05f);
  EXPECT_LT(err[err.size() * 95 / 100], 0.3f);
}

TEST(StereoDepth, AddsTheCamerasDisparityOffsetToEveryDisparity) {
  // A right image whose principal point is 1.4 px right of the left's (cx_right - cx_left =
  // 1.4): measured 11.3 - 1.4 = 9.9 px, corrected back to 11.3 by the camera's offset, at every
  // level.
  const cv::Mat left = texture(400, 200, 6);
  const double d = 11.3, offset = 1.4;
  cv::Mat right;
  const cv::Mat M = (cv::Mat_<double>(2, 3) << 1, 0, d - offset, 0, 1, 0);
  cv::warpAffine(left, right, M, left.size(), cv::INTER_CUBIC | cv::WARP_INVERSE_MAP);
  ImagePyramid pl, pr;
  ASSERT_TRUE(pl.build(left, 2).ok());
  ASSERT_TRUE(pr.build(right, 2).ok());
  const StereoDepth depth(StereoDepth::Options{});
  const StereoCamera with_offset = cameraOf(left, offset), without = cameraOf(left);
  EXPECT_EQ(with_offset.disparityOffsetPx(), offset);
  std::vector<float> err, uncorrected;
  for (int l = 0; l < 2; ++l) {
    for (int v = 20; v < pl.level(l).rows - 20; v += 15) {
      for (int u = 60; u < pl.level(l).cols - 20; u += 15) {
        const Keypoint k{float(u), float(v), 0, int8_t(l)};
        const float got = depth.disparity(with_offset, pl, pr, k);
        const float raw = depth.disparity(without, pl, pr, k);
        if (std::isfinite(got)) err.push_back(std::abs(got - static_cast<float>(d)));
        if (std::isfinite(raw)) uncorrected.push_back(raw);
      }
    }
  }
  ASSERT_GT(err.size(), 100u);
  std::sort(err.begin(), err.end());
  EXPECT_LT(err[err.size() / 2], 0.05f);
  std::sort(uncorrected.begin(), uncorrected.end());
  EXPECT_NEAR(uncorrected[uncorrected.size() / 2], d - offset, 0.05);
}

TEST(StereoDepth, GivesNoDepthOnRepeatedTextureOrFlatImages) {
  // Vertical stripes of period 8 px: every disparity d + 8k matches as well as d.
  cv::Mat stripes(100, 300, CV_8UC1);
  for (int x = 0; x < stripes.cols; ++x) {
    stripes.col(x).setTo(cv::Scalar(128 + 100 * std::sin(2 * M_PI * x / 8.0)));
  }
  cv::Mat flat(100, 300, CV_8UC1, cv::Scalar(100));
  StereoDepth depth(StereoDepth::Options{});
  for (const cv::Mat* image : {&stripes, &flat}) {
    ImagePyramid pl, pr;
    ASSERT_TRUE(pl.build(*image, 1).ok());
    ASSERT_TRUE(pr.build(*image, 1).ok());
    for (int u = 150; u < 250; u += 7) {
      EXPECT_TRUE(
          std::isnan(depth.disparity(cameraOf(*image), pl, pr, Keypoint{float(u), 50.0f, 0, 0})));
    }
  }
}

TEST(StereoFeatures, DepthOfARenderedRoomMatchesTheTruth) {
  const testing::TexturedRoom room(testing::dataRoot());
  if (!room.ok()) GTEST_SKIP() << "room textures not found";
  const StereoCamera camera = testing::syntheticCamera();
  const SE3d pose(SO3d::exp(Vec3(0.0, 0.4, 0.0)), Vec3(0.3, 0.1, -1.0));
  cv::Mat left, right;
  cv::RNG rng(9);
  room.render(camera, pose, &left, &right, &rng);
  auto extractor = StereoFeatureExtractor::create(StereoFeatureExtractor::Options{});
  ASSERT_TRUE(extractor.ok());
  FeatureFrame frame;
  ASSERT_TRUE(extractor->extract(camera, 7, left, right, &frame).ok());
  EXPECT_EQ(frame.utime, 7);
  ASSERT_GT(frame.features.size(), 300u);
  std::vector<double> err;
  int wrong = 0;
  for (const StereoFeature& f : frame.features) {
    const double z = testing::TexturedRoom::depthAt(camera, pose, f.uv.x(), f.uv.y());
    const double e = std::abs(f.disparity - camera.disparityFromDepth(z));
    err.push_back(e);
    if (e > 1.0) ++wrong;
    EXPECT_NEAR(f.point.z(), camera.depthFromDisparity(f.disparity), 1e-9);
  }
  std::sort(err.begin(), err.end());
  EXPECT_LT(err[err.size() / 2], 0.1);
  EXPECT_LT(wrong, static_cast<int>(frame.features.size() / 50));
  // Wrong sizes are refused with the image named.
  const Status s = extractor->extract(camera, 8, left, right(cv::Rect(0, 0, 100, 100)), &frame);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("right image"), std::string::npos);
}

TEST(OrbExtractor, DescriptorsSurviveARotationOfTheImage) {
  const cv::Mat a = realOrSynthetic();
  // b: a turned by 30° about the centre.
  const cv::Point2f centre(a.cols / 2.0f, a.rows / 2.0f);
  const cv::Mat M = cv::getRotationMatrix2D(centre, 30.0, 1.0);
  cv::Mat b;
  cv::warpAffine(a, b, M, a.size(), cv::INTER_LINEAR);
  ImagePyramid pa, pb;
  ASSERT_TRUE(pa.build(a, 1).ok());
  ASSERT_TRUE(pb.build(b, 1).ok());
  FastDetector::Options fo;
  FastDetector fast(fo);
  std::vector<Keypoint> ka = fast.detect(pa, 1), kb;
  std::vector<Keypoint> kept;
  for (const Keypoint& k : ka) {
    const double x = M.at<double>(0, 0) * k.u + M.at<double>(0, 1) * k.v + M.at<double>(0, 2);
    const double y = M.at<double>(1, 0) * k.u + M.at<double>(1, 1) * k.v + M.at<double>(1, 2);
    if (std::hypot(x - centre.x, y - centre.y) > 180) continue;  // stay inside both images
    kept.push_back(k);
    kb.push_back(
        Keypoint{static_cast<float>(std::round(x)), static_cast<float>(std::round(y)), k.score, 0});
  }
  ASSERT_GT(kept.size(), 30u);
  OrbExtractor orb(OrbExtractor::Options{});
  const auto da = orb.compute(pa, kept);
  const auto db = orb.compute(pb, kb);
  std::vector<int> same, other;
  for (size_t i = 0; i < kept.size(); ++i) {
    if (!da[i] || !db[i]) continue;
    same.push_back(hammingDistance(*da[i], *db[i]));
    const size_t j = (i + kept.size() / 2) % kept.size();
    if (db[j]) other.push_back(hammingDistance(*da[i], *db[j]));
  }
  ASSERT_GT(same.size(), 20u);
  std::sort(same.begin(), same.end());
  std::sort(other.begin(), other.end());
  EXPECT_LT(same[same.size() / 2], 50);    // the same corner: few bits differ
  EXPECT_GT(other[other.size() / 2], 90);  // another corner: about half of 256
}

TEST(OrbExtractor, OrientationPointsTowardsTheBrightSide) {
  cv::Mat image(100, 100, CV_8UC1);
  for (int y = 0; y < 100; ++y) {
    for (int x = 0; x < 100; ++x) image.at<uint8_t>(y, x) = static_cast<uint8_t>(x + 50);
  }
  EXPECT_NEAR(OrbExtractor::orientationDeg(image, 50, 50), 0.0, 1.0);
  EXPECT_NEAR(OrbExtractor::orientationDeg(image.t(), 50, 50), 90.0, 1.0);
  // Corners too close to the border get no descriptor.
  ImagePyramid p;
  ASSERT_TRUE(p.build(texture(200, 200, 8), 1).ok());
  OrbExtractor orb(OrbExtractor::Options{});
  const auto d = orb.compute(p, {Keypoint{5, 100, 1, 0}, Keypoint{100, 100, 1, 0}});
  EXPECT_FALSE(d[0].has_value());
  EXPECT_TRUE(d[1].has_value());
}

}  // namespace
}  // namespace evermap::core
