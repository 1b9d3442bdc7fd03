// core/camera StereoCamera: projection round trips, Jacobians against numerical derivatives,
// the back-projection covariance against a Monte Carlo, and refusal of inconsistent models.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "core/camera/stereo_camera.h"

namespace evermap::core {
namespace {

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;

// The EuRoC rig after rectification, roughly (fx != fy on purpose: catches a swapped ratio).
StereoCamera eurocLike() {
  return StereoCamera::create(435.2, 431.9, 367.4, 252.2, 0.110, 752, 480).value();
}

std::vector<Vec3> samplePoints() {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> x(-3.0, 3.0), y(-2.0, 2.0), z(0.5, 20.0);
  std::vector<Vec3> out;
  for (int i = 0; i < 50; ++i) out.emplace_back(x(rng), y(rng), z(rng));
  return out;
}

template <typename F>
Mat3 numericJacobian(F f, const Vec3& x) {
  const double h = 1e-6;
  Mat3 J;
  for (int i = 0; i < 3; ++i) {
    Vec3 d = Vec3::Zero();
    d[i] = h;
    J.col(i) = (f(x + d) - f(x - d)) / (2.0 * h);
  }
  return J;
}

TEST(StereoCamera, ProjectThenBackProjectReturnsThePoint) {
  const StereoCamera cam = eurocLike();
  for (const Vec3& p : samplePoints()) {
    const auto uvd = cam.project(p);
    ASSERT_TRUE(uvd.has_value());
    const auto back = cam.backProject(*uvd);
    ASSERT_TRUE(back.has_value());
    EXPECT_LT((*back - p).norm(), 1e-12 * p.norm()) << p.transpose();
  }
}

TEST(StereoCamera, DisparityIsTheShiftBetweenLeftAndRightImages) {
  // The right camera sits at +b along x: project p - (b, 0, 0) with the same pinhole.
  const StereoCamera cam = eurocLike();
  const Vec3 p(0.4, -0.3, 2.5);
  const Vec3 uvd = *cam.project(p);
  const Vec3 p_right = p - Vec3(cam.baselineM(), 0.0, 0.0);
  const double u_right = cam.fx() * p_right.x() / p_right.z() + cam.cx();
  EXPECT_NEAR(uvd.x() - u_right, uvd.z(), 1e-12);
  EXPECT_NEAR(uvd.z(), cam.fx() * cam.baselineM() / 2.5, 1e-12);
}

TEST(StereoCamera, DepthAndDisparityAreInverse) {
  const StereoCamera cam = eurocLike();
  for (double z : {0.3, 1.0, 7.5, 100.0}) {
    EXPECT_NEAR(cam.depthFromDisparity(cam.disparityFromDepth(z)), z, 1e-12 * z);
  }
  EXPECT_NEAR(cam.depthFromDisparity(47.872), 435.2 * 0.110 / 47.872, 1e-12);
  EXPECT_TRUE(std::isinf(cam.depthFromDisparity(0.0)));
}

TEST(StereoCamera, PointsBehindTheCameraAndNonPositiveDisparitiesAreRejected) {
  const StereoCamera cam = eurocLike();
  EXPECT_FALSE(cam.project(Vec3(0.1, 0.2, 0.0)).has_value());
  EXPECT_FALSE(cam.project(Vec3(0.1, 0.2, -1.0)).has_value());
  EXPECT_FALSE(cam.project(Vec3(std::nan(""), 0.2, 1.0)).has_value());
  EXPECT_FALSE(cam.backProject(Vec3(100.0, 100.0, 0.0)).has_value());
  EXPECT_FALSE(cam.backProject(Vec3(100.0, 100.0, -2.0)).has_value());
  EXPECT_FALSE(cam.backProject(Vec3(100.0, std::nan(""), 2.0)).has_value());
}

TEST(StereoCamera, ProjectionJacobianMatchesNumericalDerivative) {
  const StereoCamera cam = eurocLike();
  for (const Vec3& p : samplePoints()) {
    Mat3 J;
    ASSERT_TRUE(cam.project(p, &J).has_value());
    const Mat3 Jn = numericJacobian([&](const Vec3& x) { return *cam.project(x); }, p);
    EXPECT_LT((J - Jn).norm(), 1e-6 * std::max(1.0, J.norm())) << "J\n" << J << "\nnum\n" << Jn;
  }
}

TEST(StereoCamera, BackProjectionJacobianMatchesNumericalDerivative) {
  const StereoCamera cam = eurocLike();
  for (const Vec3& p : samplePoints()) {
    const Vec3 uvd = *cam.project(p);
    Mat3 J;
    ASSERT_TRUE(cam.backProject(uvd, &J).has_value());
    const Mat3 Jn = numericJacobian([&](const Vec3& x) { return *cam.backProject(x); }, uvd);
    EXPECT_LT((J - Jn).norm(), 1e-6 * std::max(1.0, J.norm())) << "J\n" << J << "\nnum\n" << Jn;
    // The two Jacobians are inverse of each other (the maps are).
    Mat3 Jp;
    cam.project(p, &Jp);
    EXPECT_LT((J * Jp - Mat3::Identity()).norm(), 1e-9);
  }
}

TEST(StereoCamera, BackProjectionCovarianceMatchesMonteCarlo) {
  // Pixel noise 0.5 px, disparity noise 0.3 px, on a point at 3 m (d ≈ 16 px): the noise is
  // small against d, where the first-order model should hold to a few percent.
  const StereoCamera cam = eurocLike();
  const Vec3 p(0.8, -0.4, 3.0);
  const Vec3 uvd = *cam.project(p);
  const double s_px = 0.5, s_d = 0.3;
  const Mat3 predicted = cam.backProjectionCovariance(uvd, s_px, s_d);

  std::mt19937 rng(3);
  std::normal_distribution<double> n(0.0, 1.0);
  const int kSamples = 200000;
  std::vector<Vec3> samples;
  samples.reserve(kSamples);
  Vec3 mean = Vec3::Zero();
  for (int i = 0; i < kSamples; ++i) {
    const Vec3 noisy = uvd + Vec3(s_px * n(rng), s_px * n(rng), s_d * n(rng));
    samples.push_back(*cam.backProject(noisy));
    mean += samples.back();
  }
  mean /= kSamples;
  Mat3 sample_cov = Mat3::Zero();
  for (const Vec3& s : samples) sample_cov += (s - mean) * (s - mean).transpose();
  sample_cov /= kSamples - 1;

  // Per-entry agreement relative to the standard deviations involved.
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      const double scale = std::sqrt(predicted(r, r) * predicted(c, c));
      EXPECT_NEAR(sample_cov(r, c) / scale, predicted(r, c) / scale, 0.03)
          << "entry (" << r << "," << c << ")\npredicted\n"
          << predicted << "\nsampled\n"
          << sample_cov;
    }
  }
  // Depth dominates: σ_z = z² σ_d / (fx b).
  EXPECT_NEAR(std::sqrt(predicted(2, 2)), 9.0 * s_d / (cam.fx() * cam.baselineM()), 1e-12);
}

TEST(StereoCamera, InconsistentModelsAreRefusedNamingTheField) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  struct Case {
    double fx, fy, cx, cy, b;
    int w, h;
    const char* expected;
  };
  const std::vector<Case> cases = {
      {0.0, 400, 320, 240, 0.1, 640, 480, "fx = 0"},
      {-400, 400, 320, 240, 0.1, 640, 480, "fx = -400"},
      {nan, 400, 320, 240, 0.1, 640, 480, "fx = nan"},
      {400, 0.0, 320, 240, 0.1, 640, 480, "fy = 0"},
      {400, nan, 320, 240, 0.1, 640, 480, "fy = nan"},
      {400, 400, 320, 240, 0.0, 640, 480, "baseline = 0"},
      {400, 400, 320, 240, -0.1, 640, 480, "baseline = -0.1"},
      {400, 400, 320, 240, nan, 640, 480, "baseline = nan"},
      {400, 400, 320, 240, 0.1, 0, 480, "image size 0x480"},
      {400, 400, 320, 240, 0.1, 640, -1, "image size 640x-1"},
      {400, 400, 700, 240, 0.1, 640, 480, "principal point (700, 240) is outside"},
      {400, 400, 320, -5, 0.1, 640, 480, "principal point (320, -5) is outside"},
      {400, 400, nan, 240, 0.1, 640, 480, "principal point (nan, 240) is outside"},
  };
  for (const Case& c : cases) {
    const auto cam = StereoCamera::create(c.fx, c.fy, c.cx, c.cy, c.b, c.w, c.h);
    ASSERT_FALSE(cam.ok()) << c.expected;
    EXPECT_NE(cam.error().message.find(c.expected), std::string::npos)
        << "got: " << cam.error().message << "\nwanted: " << c.expected;
  }
  EXPECT_TRUE(StereoCamera::create(400, 400, 320, 240, 0.1, 640, 480).ok());
}

TEST(StereoCamera, TheRowSlopeCorrectsDisparitiesInProportionToTheRowsDistanceFromCy) {
  EXPECT_EQ(eurocLike().disparityRowSlope(), 0.0);
  EXPECT_EQ(eurocLike().disparityCorrectionPx(10.0), 0.0);
  const auto kitti =
      StereoCamera::create(718.856, 718.856, 607.1928, 185.2157, 0.537, 1241, 376, 1.3, 0.004);
  ASSERT_TRUE(kitti.ok()) << kitti.error().message;
  EXPECT_DOUBLE_EQ(kitti->disparityCorrectionPx(185.2157), 1.3);
  EXPECT_DOUBLE_EQ(kitti->disparityCorrectionPx(285.2157), 1.7);
  EXPECT_DOUBLE_EQ(kitti->disparityCorrectionPx(85.2157), 0.9);
  EXPECT_NE(kitti->describe().find("disparity_row_slope=+0.00400"), std::string::npos)
      << kitti->describe();
  EXPECT_EQ(eurocLike().describe().find("disparity_row_slope"), std::string::npos);
  // Bounded as the offset: over the image's rows, at most a quarter of the width.
  EXPECT_TRUE(StereoCamera::create(400, 400, 320, 240, 0.1, 640, 480, 0.0, -1.0 / 3.0).ok());
  for (double bad : {0.34, -0.5, std::numeric_limits<double>::quiet_NaN()}) {
    const auto cam = StereoCamera::create(400, 400, 320, 240, 0.1, 640, 480, 0.0, bad);
    ASSERT_FALSE(cam.ok()) << bad;
    EXPECT_NE(cam.error().message.find("disparity row slope"), std::string::npos)
        << cam.error().message;
  }
}

TEST(StereoCamera, TheDisparityOffsetIsZeroByDefaultAndBoundedByAQuarterOfTheWidth) {
  EXPECT_EQ(eurocLike().disparityOffsetPx(), 0.0);
  const auto kitti =
      StereoCamera::create(718.856, 718.856, 607.1928, 185.2157, 0.537, 1241, 376, 0.8);
  ASSERT_TRUE(kitti.ok()) << kitti.error().message;
  EXPECT_EQ(kitti->disparityOffsetPx(), 0.8);
  EXPECT_NE(kitti->describe().find("disparity_offset=+0.800px"), std::string::npos)
      << kitti->describe();
  EXPECT_EQ(eurocLike().describe().find("disparity_offset"), std::string::npos);
  EXPECT_TRUE(StereoCamera::create(400, 400, 320, 240, 0.1, 640, 480, -160.0).ok());
  for (double bad : {160.5, -161.0, std::numeric_limits<double>::infinity(),
                     std::numeric_limits<double>::quiet_NaN()}) {
    const auto cam = StereoCamera::create(400, 400, 320, 240, 0.1, 640, 480, bad);
    ASSERT_FALSE(cam.ok()) << bad;
    EXPECT_NE(cam.error().message.find("disparity offset cx_right - cx_left"), std::string::npos)
        << cam.error().message;
    EXPECT_NE(cam.error().message.find("quarter of the 640 px width"), std::string::npos)
        << cam.error().message;
  }
}

TEST(StereoCamera, TheDisparityOffsetLeavesTheModelsProjectionAlone) {
  // The offset concerns only disparities measured between the images (StereoDepth): project
  // and backProject are those of the model, d = fx b / z, with or without it.
  const StereoCamera plain = eurocLike();
  const StereoCamera offset =
      *StereoCamera::create(435.2, 431.9, 367.4, 252.2, 0.110, 752, 480, 0.8);
  for (const Vec3& p : samplePoints()) {
    EXPECT_EQ(*plain.project(p), *offset.project(p));
    const Vec3 uvd = *plain.project(p);
    EXPECT_EQ(*plain.backProject(uvd), *offset.backProject(uvd));
  }
}

}  // namespace
}  // namespace evermap::core
