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

// Runs f with the AVX2 paths allowed, then without; restores the setting it found.
template <typename F>
auto bothPaths(F f) {
  struct Restore {
    bool previous = avx2Allowed();
    ~Restore() { avx2Allowed() = previous; }
  } restore;
  avx2Allowed() = true;
  auto vectorised = f();
  avx2Allowed() = false;
  auto portable = f();
  return std::make_pair(vectorised, portable);
}

bool skipWithoutAvx2() { return !cpuHasAvx2(); }

// The right image of a fronto-parallel scene whose disparity grows from 2 px at the left to
// about 60 px at the right: the best disparity falls in every block of the curve.
cv::Mat rightWithVaryingDisparity(const cv::Mat& left) {
  cv::Mat map_x(left.size(), CV_32FC1), map_y(left.size(), CV_32FC1);
  for (int v = 0; v < left.rows; ++v) {
    for (int u = 0; u < left.cols; ++u) {
      const float d = 2.0f + 58.0f * static_cast<float>(u) / static_cast<float>(left.cols);
      map_x.at<float>(v, u) = static_cast<float>(u) + d;  // right(u) = left(u + d)
      map_y.at<float>(v, u) = static_cast<float>(v);
    }
  }
  cv::Mat right;
  cv::remap(left, right, map_x, map_y, cv::INTER_CUBIC, cv::BORDER_REFLECT);
  return right;
}

TEST(SimdPaths, StereoDisparitiesAgreeOnEveryCornerUpToTheRightBorder) {
  if (skipWithoutAvx2()) GTEST_SKIP() << "this CPU has no AVX2: only the portable path exists";
  const cv::Mat left = texture(331, 120, 3, 1.5);
  ImagePyramid pl_shift, pr_shift, pl_vary, pr_vary;
  ASSERT_TRUE(pl_shift.build(left, 3).ok());
  ASSERT_TRUE(pr_shift.build(shifted(left, 17.4, 0.0), 3).ok());
  ASSERT_TRUE(pl_vary.build(left, 3).ok());
  ASSERT_TRUE(pr_vary.build(rightWithVaryingDisparity(left), 3).ok());
  const StereoCamera camera = *StereoCamera::create(300.0, 300.0, left.cols / 2.0, left.rows / 2.0,
                                                    0.1, left.cols, left.rows);
  struct Pair {
    const ImagePyramid* left;
    const ImagePyramid* right;
  };
  // Search ranges shorter than one 32-disparity block (portable on both sides), exactly one,
  // a block and one, and several, at every level, up to the image border. Without the
  // sub-pixel step the disparity is the integer minimum of the SAD curve: the curves' integer
  // costs must agree exactly for every corner to get the same one.
  for (const Pair& pair : {Pair{&pl_shift, &pr_shift}, Pair{&pl_vary, &pr_vary}}) {
    for (int max_disparity : {20, 31, 32, 40, 64, 128}) {
      for (bool subpixel : {false, true}) {
        StereoDepth::Options o;
        o.max_disparity_px = max_disparity;
        o.subpixel = subpixel;
        const StereoDepth depth(o);
        const auto [vectorised, portable] = bothPaths([&] {
          std::vector<float> d;
          for (int l = 0; l < 3; ++l) {
            for (int v = 5; v < pair.left->level(l).rows - 5; v += 3) {
              for (int u = 4; u < pair.left->level(l).cols - 4; u += 1) {
                d.push_back(depth.disparity(camera, *pair.left, *pair.right,
                                            Keypoint{float(u), float(v), 0, int8_t(l)}));
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
          if (subpixel) {
            EXPECT_NEAR(vectorised[i], portable[i], 1e-3f) << i;
          } else {
            EXPECT_EQ(vectorised[i], portable[i]) << i;
          }
        }
        EXPECT_GT(found, 500) << "max disparity " << max_disparity;
      }
    }
  }
}

TEST(SimdPaths, PatchAlignmentAgreesInOneAndTwoDimensionsAndAtTheBorders) {
  if (skipWithoutAvx2()) GTEST_SKIP() << "this CPU has no AVX2: only the portable path exists";
  const cv::Mat a = texture(120, 90, 4, 1.5);
  const cv::Mat b = shifted(a, 0.37, -0.61);
  for (int radius : {1, 2, 3, 4, 5, 6, 7, 8}) {
    for (bool x_only : {false, true}) {
      PatchAlignmentOptions o;
      o.radius_px = radius;
      o.x_only = x_only;
      const auto [vectorised, portable] = bothPaths([&] {
        std::vector<std::optional<Eigen::Vector2f>> out;
        for (int v = 0; v < a.rows; v += 7) {
          for (int u = 0; u < a.cols; ++u) {  // every column: the right border included
            out.push_back(alignPatch(a, u, v, b, Eigen::Vector2f(u, v), o));
            // A start between rows: the 1-D case keeps it, and must weigh the next row too.
            out.push_back(alignPatch(a, u, v, b, Eigen::Vector2f(u, v - 0.61f), o));
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
  const StereoCamera camera =
      *StereoCamera::create(718.856, 718.856, 607.19, 185.22, 0.537, 1241, 376);
  // Turned and shifted both ways, so that samples fall on the first and the last columns.
  for (double dx : {3.6, -3.6}) {
    const cv::Mat b = shifted(a, dx, -1.2);
    const auto [vectorised, portable] =
        bothPaths([&] { return estimateRotation(a, b, camera, 3, RotationEstimateOptions{}); });
    ASSERT_TRUE(vectorised.has_value()) << dx;
    ASSERT_TRUE(portable.has_value()) << dx;
    EXPECT_LT(rotationAngle(vectorised->inverse() * *portable), 1e-5) << dx;
    EXPECT_GT(rotationAngle(*vectorised), 0.01) << dx;  // it did turn
  }
}

TEST(SimdPaths, BothPathsRestoresTheSettingItFound) {
  avx2Allowed() = false;
  bothPaths([] { return 0; });
  EXPECT_FALSE(avx2Allowed());
  avx2Allowed() = true;
  bothPaths([] { return 0; });
  EXPECT_TRUE(avx2Allowed());
}

}  // namespace
}  // namespace evermap::core
