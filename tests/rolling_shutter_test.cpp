// core/camera/rolling_shutter.h and the line delay's evidence (pairLineDelayCurve,
// core/registration/disparity_offset.h) on synthetic geometry: points seen by a turning camera
// whose rows are exposed one after another, each point at the row it lands on.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "core/camera/rolling_shutter.h"
#include "core/geometry/se3.h"
#include "core/registration/curve_evidence.h"
#include "core/registration/disparity_offset.h"

namespace evermap::core {
namespace {

StereoCamera kinectLike() {
  // A Kinect's color camera as an equivalent stereo rig (core/camera/rgbd_camera.h).
  auto camera = StereoCamera::create(517.3, 516.5, 318.6, 255.3, 0.271, 640, 480);
  EXPECT_TRUE(camera.ok());
  return *camera;
}

// (u, v, d) of world point x seen by a rolling-shutter camera whose middle row's pose is
// world_T_mid, turning at omega (rad/s, its frame): the row read at t(v) sees x from
// world_T_mid exp(omega (t(v) - t_mid)), and v is where x lands from there (a fixed point).
std::optional<Vec3> rollingObservation(const StereoCamera& camera, const SE3d& world_T_mid,
                                       const Vec3& omega, double line_delay_s, const Vec3& x) {
  const Vec3 p_mid = world_T_mid.inverse() * x;
  auto uvd = camera.project(p_mid);
  for (int it = 0; it < 20 && uvd; ++it) {
    const double dt = (uvd->y() - camera.cy()) * line_delay_s;
    uvd = camera.project(SO3d::exp(omega * dt).inverse() * p_mid);
  }
  if (!uvd || !camera.inImage(uvd->x(), uvd->y())) return std::nullopt;
  return uvd;
}

// Points on the walls of a room 1-4 m in front of the camera.
std::vector<Vec3> scene(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> xy(-1.5, 1.5), z(1.0, 4.0);
  std::vector<Vec3> points;
  for (int i = 0; i < n; ++i) points.emplace_back(xy(rng), xy(rng), z(rng));
  return points;
}

TEST(RollingShutter, MovesAFeatureToWhereTheMiddleRowsCameraSeesIt) {
  const StereoCamera camera = kinectLike();
  const Vec3 omega(0.4, 1.1, -0.3);  // rad/s: a hand-held turn, ~70 deg/s
  const double delay = 40e-6;
  double worst = 0.0, worst_uncorrected = 0.0;
  int seen = 0;
  for (const Vec3& x : scene(200, 3)) {
    const auto observed = rollingObservation(camera, SE3d(), omega, delay, x);
    if (!observed) continue;
    ++seen;
    const Vec3 truth = *camera.project(x);
    const auto corrected = toMiddleRow(camera, *observed, omega, delay);
    ASSERT_TRUE(corrected.has_value());
    worst = std::max(worst, (*corrected - truth).head<2>().norm());
    worst_uncorrected = std::max(worst_uncorrected, (*observed - truth).head<2>().norm());
  }
  ASSERT_GT(seen, 100);
  // The row a feature is seen at is the one it was exposed at: the correction is exact.
  EXPECT_LT(worst, 1e-6);
  EXPECT_GT(worst_uncorrected, 3.0);  // pixels, at the image's top and bottom rows
  // No turn, or a global shutter: nothing moves.
  const Vec3 uvd(100.0, 400.0, 40.0);
  EXPECT_EQ(*toMiddleRow(camera, uvd, Vec3::Zero(), delay), uvd);
  EXPECT_EQ(*toMiddleRow(camera, uvd, omega, 0.0), uvd);
}

// A pair of rolling-shutter frames of the scene: a turning between them, each frame with its
// own angular velocity (a hand-held camera's changes from frame to frame).
StereoMatchPair rollingPair(const StereoCamera& camera, double line_delay_s, const Vec3& omega_a,
                            const Vec3& omega_b, const SE3d& a_T_b, unsigned seed) {
  StereoMatchPair pair;
  pair.omega_a = omega_a;
  pair.omega_b = omega_b;
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 0.3);
  for (const Vec3& x : scene(150, seed)) {
    const auto a = rollingObservation(camera, SE3d(), omega_a, line_delay_s, x);
    const auto b = rollingObservation(camera, a_T_b, omega_b, line_delay_s, x);
    if (!a || !b) continue;
    pair.uvd_a.push_back(*a + Vec3(noise(rng), noise(rng), 0.1 * noise(rng)));
    pair.uvd_b.push_back(*b + Vec3(noise(rng), noise(rng), 0.1 * noise(rng)));
  }
  pair.a_T_b = a_T_b;  // the solves start from the truth; each re-solves the motion
  return pair;
}

// Evidence over candidate delays -40 .. 100 us by 5 us (*grid_s: the same in seconds).
CurveEvidence lineDelayEvidence(std::vector<double>* grid_s) {
  const std::vector<double> grid_us = evenGrid(-40.0, 100.0, 5.0);
  for (double us : grid_us) grid_s->push_back(us * 1e-6);
  return CurveEvidence(grid_us, CurveEvidenceOptions{20.0, 5, 100, 3.0, 10.0});
}

// The delay the summed curves of 10 pairs (different turns) put their least cost at.
double estimatedDelayUs(double true_delay_s, double turn_scale) {
  const StereoCamera camera = kinectLike();
  std::vector<double> grid_s;
  CurveEvidence evidence = lineDelayEvidence(&grid_s);
  for (unsigned k = 0; k < 10; ++k) {
    const double s = turn_scale * (k % 2 == 0 ? 1.0 : -1.0);
    const Vec3 omega_a = s * Vec3(0.3, 1.2 + 0.1 * k, 0.2);
    const Vec3 omega_b = s * Vec3(-0.2, 0.6, 0.5 - 0.05 * k);
    const SE3d a_T_b(SO3d::exp(Vec3(0.01, 0.04, 0.005) * s), Vec3(0.01, -0.005, 0.004));
    evidence.add(pairLineDelayCurve(
                     camera, rollingPair(camera, true_delay_s, omega_a, omega_b, a_T_b, 11 + k),
                     grid_s, DisparityOffsetOptions{}),
                 k);
  }
  EXPECT_GE(evidence.estimate().groups_used, 5);
  std::printf("true %.1f us: estimate %.2f +- %.2f us from %d pairs\n", true_delay_s * 1e6,
              evidence.estimate().value, evidence.estimate().standard_error,
              evidence.estimate().pairs_used);
  return evidence.estimate().value;
}

TEST(RollingShutterEvidence, ThePairsCurvesFindTheLineDelay) {
  EXPECT_NEAR(estimatedDelayUs(40e-6, 1.0), 40.0, 4.0);
  EXPECT_NEAR(estimatedDelayUs(20e-6, 1.0), 20.0, 4.0);
}

TEST(RollingShutterEvidence, AGlobalShutterIsFoundToHaveNone) {
  EXPECT_NEAR(estimatedDelayUs(0.0, 1.0), 0.0, 4.0);
}

TEST(RollingShutterEvidence, ACameraThatDoesNotTurnGivesNoEvidence) {
  const StereoCamera camera = kinectLike();
  std::vector<double> grid_s;
  CurveEvidence evidence = lineDelayEvidence(&grid_s);
  for (unsigned k = 0; k < 10; ++k) {
    const SE3d a_T_b(SO3d(), Vec3(0.05, 0.0, 0.02 * k));
    evidence.add(pairLineDelayCurve(
                     camera, rollingPair(camera, 40e-6, Vec3::Zero(), Vec3::Zero(), a_T_b, 31 + k),
                     grid_s, DisparityOffsetOptions{}),
                 k);
  }
  EXPECT_EQ(evidence.estimate().pairs_examined, 10);
  EXPECT_EQ(evidence.estimate().pairs_used, 0);
  EXPECT_FALSE(std::isfinite(evidence.estimate().standard_error));
}

}  // namespace
}  // namespace evermap::core
