// The AVX2 paths of the VO's inner loops against their portable twins (core::avx2Allowed off):
// the SAD disparity curve (exact integers: the same integer disparity), the patch alignment
// (float sums in another order: the same position to 1e-3 px), the rotation prior (the same
// rotation to 1e-5 rad). Skipped on a CPU without AVX2, where only the portable paths exist.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "core/common/cpu.h"
#include "core/features/image_pyramid.h"
#include "core/features/patch_alignment.h"
#include "core/features/stereo_depth.h"
#include "core/registration/rotation_estimation.h"

namespace evermap::core {
namespace {

cv::Mat texture(int width, int height, uint64_t seed, double blur) {
  cv::Mat noise(height, width, CV_8UC1);
  cv::RNG rng(seed);
  rng.fill(noise, cv::RNG::UNIFORM, 0, 256);
  cv::Mat smooth;
  cv::GaussianBlur(noise, smooth, cv::Size(0, 0), blur);
  cv::normalize(smooth, smooth, 0, 255, cv::NORM_MINMAX);
  return smooth;
}

cv::Mat shifted(const cv::Mat& a, double dx, double dy) {
  cv::Mat b;
  const cv::Mat M = (cv::Mat_<double>(2, 3) << 1, 0, dx, 0, 1, dy);
  cv::warpAffine(a, b, M, a.size(), cv::INTER_CUBIC | cv::WARP_INVERSE_MAP, cv::BORDER_REFLECT);
  return b;
}

// Runs f with the AVX2 paths allowed, then without; restores the setting.
template <typename F>
auto bothPaths(F f) {
  struct Restore {
    ~Restore() { avx2Allowed() = true; }
  } restore;
  avx2Allowed() = true;
  auto vectorised = f();
  avx2Allowed() = false;
  auto portable = f();
  return std::make_pair(vectorised, portable);
}

bool skipWithoutAvx2() { return !cpuHasAvx2(); }

TEST(SimdPaths, StereoDisparitiesAgreeOnEveryCornerUpToTheRightBorder) {
  if (skipWithoutAvx2()) GTEST_SKIP() << "this CPU has no AVX2: only the portable path exists";
  const cv::Mat left = texture(331, 120, 3, 1.5);
  const cv::Mat right = shifted(left, 17.4, 0.0);
  ImagePyramid pl, pr;
  ASSERT_TRUE(pl.build(left, 3).ok());
  ASSERT_TRUE(pr.build(right, 3).ok());
  const StereoCamera camera = *StereoCamera::create(300.0, 300.0, left.cols / 2.0,
                                                    left.rows / 2.0, 0.1, left.cols, left.rows);
  // Search ranges below and above a 32-disparity block at every level, up to the border.
  for (int max_disparity : {20, 40, 128}) {
    StereoDepth::Options o;
    o.max_disparity_px = max_disparity;
    const StereoDepth depth(o);
    const auto [vectorised, portable] = bothPaths([&] {
      std::vector<float> d;
      for (int l = 0; l < 3; ++l) {
        for (int v = 5; v < pl.level(l).rows - 5; v += 3) {
          for (int u = 4; u < pl.level(l).cols - 4; u += 1) {
            d.push_back(depth.disparity(camera, pl, pr, Keypoint{float(u), float(v), 0, int8_t(l)}));
          }
        }
      }
      return d;
    });
    ASSERT_EQ(vectorised.size(), portable.size());
    int found = 0;
    for (size_t i = 0; i < vectorised.size(); ++i) {
      ASSERT_EQ(std::isfinite(vectorised[i]), std::isfinite(portable[i])) << i;
      if (!std::isfinite(vectorised[i])) continue;
      ++found;
      EXPECT_NEAR(vectorised[i], portable[i], 1e-3f) << i;
    }
    EXPECT_GT(found, 1000) << "max disparity " << max_disparity;
  }
}

TEST(SimdPaths, PatchAlignmentAgreesInOneAndTwoDimensionsAndAtTheBorders) {
  if (skipWithoutAvx2()) GTEST_SKIP() << "this CPU has no AVX2: only the portable path exists";
  const cv::Mat a = texture(120, 90, 4, 1.5);
  const cv::Mat b = shifted(a, 0.37, -0.61);
  for (int radius : {2, 3, 4, 7, 8}) {
    for (bool x_only : {false, true}) {
      PatchAlignmentOptions o;
      o.radius_px = radius;
      o.x_only = x_only;
      const auto [vectorised, portable] = bothPaths([&] {
        std::vector<std::optional<Eigen::Vector2f>> out;
        for (int v = 0; v < a.rows; v += 7) {
          for (int u = 0; u < a.cols; ++u) {  // every column: the right border included
            out.push_back(alignPatch(a, u, v, b, Eigen::Vector2f(u, v), o));
          }
        }
        return out;
      });
      int found = 0;
      for (size_t i = 0; i < vectorised.size(); ++i) {
        ASSERT_EQ(vectorised[i].has_value(), portable[i].has_value()) << radius << " " << i;
        if (!vectorised[i]) continue;
        ++found;
        EXPECT_LT((*vectorised[i] - *portable[i]).norm(), 1e-3f) << radius << " " << i;
      }
      EXPECT_GT(found, 100) << "radius " << radius;
    }
  }
}

TEST(SimdPaths, RotationPriorAgrees) {
  if (skipWithoutAvx2()) GTEST_SKIP() << "this CPU has no AVX2: only the portable path exists";
  const cv::Mat a = texture(155, 47, 5, 2.0);
  const StereoCamera camera = *StereoCamera::create(718.856, 718.856, 607.19, 185.22, 0.537, 1241, 376);
  // Turned and shifted so that samples fall on the first and last columns too.
  const cv::Mat b = shifted(a, 3.6, -1.2);
  const auto [vectorised, portable] =
      bothPaths([&] { return estimateRotation(a, b, camera, 3, RotationEstimateOptions{}); });
  ASSERT_TRUE(vectorised.has_value());
  ASSERT_TRUE(portable.has_value());
  EXPECT_LT(rotationAngle(vectorised->inverse() * *portable), 1e-5);
  EXPECT_GT(rotationAngle(*vectorised), 0.01);  // it did turn
}

}  // namespace
}  // namespace evermap::core
