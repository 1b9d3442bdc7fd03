// tools/eval/metrics and kitti_drift: ATE, RPE and KITTI drift against hand-computed answers.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "tools/eval/kitti_drift.h"
#include "tools/eval/metrics.h"

namespace evermap::eval {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

core::SE3d at(double x, double y = 0.0, double z = 0.0, double yaw_rad = 0.0) {
  return core::SE3d(core::SO3d::fromRollPitchYaw(0.0, 0.0, yaw_rad), core::Vec3(x, y, z));
}

TEST(ErrorStats, MatchHandComputedValues) {
  // rmse = sqrt((0.01 + 0.04 + 0.04 + 0.25) / 4) = sqrt(0.085); mean 0.25; median (0.2+0.2)/2;
  // std = sqrt((0.15² + 0.05² + 0.05² + 0.25²) / 4) = 0.15.
  const ErrorStats s = computeStats({0.5, 0.2, 0.1, 0.2});
  EXPECT_EQ(s.count, 4u);
  EXPECT_NEAR(s.rmse, std::sqrt(0.085), 1e-15);
  EXPECT_NEAR(s.mean, 0.25, 1e-15);
  EXPECT_NEAR(s.median, 0.2, 1e-15);
  EXPECT_NEAR(s.std, 0.15, 1e-15);
  EXPECT_DOUBLE_EQ(s.min, 0.1);
  EXPECT_DOUBLE_EQ(s.max, 0.5);
  EXPECT_DOUBLE_EQ(computeStats({3.0, 1.0, 2.0}).median, 2.0);
}

TEST(Ate, ConstantOffsetWithoutAlignmentIsTheOffset) {
  std::vector<core::SE3d> gt;
  std::vector<core::SE3d> est;
  for (int k = 0; k < 50; ++k) {
    gt.push_back(at(k, std::sin(k), 0.0, 0.1 * k));
    // 0.1 m off, in a direction that turns with k: the error norm is 0.1 everywhere.
    est.push_back(at(k + 0.06 * std::cos(k), std::sin(k) + 0.06 * std::sin(k), 0.08, 0.1 * k));
  }
  const auto ate = computeAte(gt, est);
  ASSERT_TRUE(ate.ok()) << ate.error().message;
  EXPECT_NEAR(ate->translation_m.rmse, 0.1, 1e-12);
  EXPECT_NEAR(ate->translation_m.mean, 0.1, 1e-12);
  EXPECT_NEAR(ate->translation_m.median, 0.1, 1e-12);
  EXPECT_NEAR(ate->translation_m.std, 0.0, 1e-9);
  EXPECT_NEAR(ate->translation_m.max, 0.1, 1e-12);
  EXPECT_NEAR(ate->rotation_deg.max, 0.0, 1e-9);
  EXPECT_EQ(ate->translation_errors_m.size(), 50u);
}

TEST(Ate, RotationErrorIsTheAngleBetweenOrientations) {
  const std::vector<core::SE3d> gt = {at(0, 0, 0, 0.0), at(1, 0, 0, 0.5)};
  const std::vector<core::SE3d> est = {at(0, 0, 0, 2 * kDeg), at(1, 0, 0, 0.5 - 4 * kDeg)};
  const auto ate = computeAte(gt, est);
  ASSERT_TRUE(ate.ok());
  EXPECT_NEAR(ate->rotation_deg.mean, 3.0, 1e-9);
  EXPECT_NEAR(ate->rotation_deg.max, 4.0, 1e-9);
  EXPECT_NEAR(ate->translation_m.max, 0.0, 1e-15);
}

TEST(Ate, BadInputsAreErrors) {
  EXPECT_FALSE(computeAte({}, {}).ok());
  EXPECT_FALSE(computeAte({at(0)}, {at(0), at(1)}).ok());
  const auto r = computeAte({at(0), at(1)}, {at(0), at(std::nan(""))});
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("matched pose 1 is not finite"), std::string::npos);
}

TEST(Rpe, TenPercentTooLongStepsGiveTenPercentTranslationError) {
  std::vector<core::SE3d> gt;
  std::vector<core::SE3d> est;
  for (int k = 0; k < 11; ++k) {
    gt.push_back(at(k));
    est.push_back(at(1.1 * k));
  }
  auto rpe = computeRpe(gt, est, {.delta_frames = 1});
  ASSERT_TRUE(rpe.ok()) << rpe.error().message;
  EXPECT_EQ(rpe->translation_m.count, 10u);
  EXPECT_NEAR(rpe->translation_m.rmse, 0.1, 1e-12);
  EXPECT_NEAR(rpe->translation_m.median, 0.1, 1e-12);
  EXPECT_NEAR(rpe->rotation_deg.max, 0.0, 1e-12);
  rpe = computeRpe(gt, est, {.delta_frames = 3});
  ASSERT_TRUE(rpe.ok());
  EXPECT_EQ(rpe->translation_m.count, 8u);
  EXPECT_NEAR(rpe->translation_m.mean, 0.3, 1e-12);
  // By distance: 2.5 m along the ground truth is reached 3 poses on (3 m): error 0.3 m.
  rpe = computeRpe(gt, est, {.delta_frames = 0, .delta_distance_m = 2.5});
  ASSERT_TRUE(rpe.ok()) << rpe.error().message;
  EXPECT_EQ(rpe->translation_m.count, 8u);
  EXPECT_NEAR(rpe->translation_m.mean, 0.3, 1e-12);
}

TEST(Rpe, HeadingDriftGivesItsAngleAndTheMatchingTranslationError) {
  // Ground truth drives along x without turning; the estimate has the same positions but its
  // heading turns 1 degree per pose. Over one step, E = (Q_i⁻¹Q_j)⁻¹(P_i⁻¹P_j) turns by
  // 1 degree, and its translation is Rz(-i°)·e_x - e_x, of length 2 sin(i°/2).
  std::vector<core::SE3d> gt;
  std::vector<core::SE3d> est;
  for (int k = 0; k < 4; ++k) {
    gt.push_back(at(k));
    est.push_back(at(k, 0, 0, k * kDeg));
  }
  const auto rpe = computeRpe(gt, est, {.delta_frames = 1});
  ASSERT_TRUE(rpe.ok());
  EXPECT_NEAR(rpe->rotation_deg.mean, 1.0, 1e-9);
  EXPECT_NEAR(rpe->rotation_deg.std, 0.0, 1e-9);
  const double e1 = 2 * std::sin(0.5 * kDeg);
  const double e2 = 2 * std::sin(1.0 * kDeg);
  EXPECT_NEAR(rpe->translation_m.median, e1, 1e-12);
  EXPECT_NEAR(rpe->translation_m.max, e2, 1e-12);
  EXPECT_NEAR(rpe->translation_m.rmse, std::sqrt((e1 * e1 + e2 * e2) / 3.0), 1e-12);
}

TEST(Rpe, BadOptionsAndTooShortTrajectoriesAreErrors) {
  const std::vector<core::SE3d> two = {at(0), at(1)};
  EXPECT_FALSE(computeRpe(two, two, {.delta_frames = 0}).ok());
  EXPECT_FALSE(computeRpe(two, two, {.delta_frames = 1, .delta_distance_m = 1.0}).ok());
  auto r = computeRpe(two, two, {.delta_frames = 2});
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("needs more than 2 matched poses"), std::string::npos);
  r = computeRpe(two, two, {.delta_frames = 0, .delta_distance_m = 5.0});
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("1 m long"), std::string::npos) << r.error().message;
}

// A straight 1 km drive along the camera's z axis (KITTI's forward), a pose every 0.5 m.
std::vector<core::SE3d> straightKilometre(double length_factor, double yaw_rad_per_m = 0.0) {
  std::vector<core::SE3d> poses;
  for (int k = 0; k <= 2000; ++k) {
    const double s = 0.5 * k;
    poses.push_back(core::SE3d(core::SO3d::fromRollPitchYaw(0.0, yaw_rad_per_m * s, 0.0),
                               core::Vec3(0.0, 0.0, length_factor * s)));
  }
  return poses;
}

TEST(KittiDrift, AnEstimateOnePercentTooLongDriftsOnePercent) {
  const auto gt = straightKilometre(1.0);
  const auto est = straightKilometre(1.01);
  const auto drift = computeKittiDrift(gt, est);
  ASSERT_TRUE(drift.ok()) << drift.error().message;
  // Each segment ends at the first pose more than L further on, L + 0.5 m: the error is
  // 1 % of (L + 0.5) divided by L, slightly above 1 %.
  EXPECT_NEAR(drift->translation_percent, 1.0, 0.005);
  EXPECT_GT(drift->translation_percent, 1.0);
  EXPECT_NEAR(drift->rotation_deg_per_100m, 0.0, 1e-9);
  ASSERT_EQ(drift->per_length.size(), 8u);
  EXPECT_NEAR(drift->per_length[0].translation_percent, 100.0 * 0.01 * 100.5 / 100.0, 1e-6);
  // Starts every 10 poses (5 m) with more than L + 0.5 m of path left: 1000 - L - 0.5 > 5k.
  EXPECT_EQ(drift->per_length[0].segments, 180u);
  EXPECT_EQ(drift->per_length[7].segments, 40u);
  size_t total = 0;
  for (const auto& row : drift->per_length) total += row.segments;
  EXPECT_EQ(drift->segments, total);
}

TEST(KittiDrift, AConstantTurnRateGivesItsRotationDrift) {
  // The estimate turns 0.001 rad per metre while the truth goes straight: over a segment of
  // L (+0.5) m, the rotation error is 0.001 (L + 0.5) rad, i.e. ~5.73 deg / 100 m.
  const auto gt = straightKilometre(1.0);
  const auto est = straightKilometre(1.0, 0.001);
  const auto drift = computeKittiDrift(gt, est);
  ASSERT_TRUE(drift.ok());
  EXPECT_NEAR(drift->per_length[0].rotation_deg_per_100m, 0.001 * 100.5 / kDeg, 1e-6);
  EXPECT_NEAR(drift->rotation_deg_per_100m, 0.1 / kDeg, 0.02);
}

TEST(KittiDrift, APathShorterThanTheShortestSegmentIsAnError) {
  std::vector<core::SE3d> gt;
  for (int k = 0; k < 100; ++k) gt.push_back(at(0.9 * k));
  const auto r = computeKittiDrift(gt, gt);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("shorter than the shortest segment (100 m)"), std::string::npos)
      << r.error().message;
  EXPECT_FALSE(computeKittiDrift(gt, gt, {.segment_lengths_m = {}, .step_frames = 10}).ok());
  EXPECT_FALSE(computeKittiDrift(gt, gt, {.segment_lengths_m = {10.0}, .step_frames = 0}).ok());
  const auto short_ok = computeKittiDrift(gt, gt, {.segment_lengths_m = {10.0}, .step_frames = 1});
  ASSERT_TRUE(short_ok.ok());
  EXPECT_NEAR(short_ok->translation_percent, 0.0, 1e-12);
}

}  // namespace
}  // namespace evermap::eval
