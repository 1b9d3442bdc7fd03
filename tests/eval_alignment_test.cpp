// tools/eval/alignment: Umeyama SE(3)/Sim(3) recovers known transforms exactly, agrees with
// Eigen::umeyama on noisy data, never returns a reflection, and reports degenerate input.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <random>

#include "eval_synthetic.h"
#include "tools/eval/alignment.h"
#include "tools/eval/metrics.h"

namespace evermap::eval {
namespace {

std::vector<core::SE3d> posesOf(const Trajectory& t) {
  std::vector<core::SE3d> out;
  for (const auto& p : t.poses) out.push_back(p.world_T_body);
  return out;
}

// The estimate as a SLAM system would report it in its own world frame: est = S⁻¹ * gt.
std::vector<core::SE3d> expressedIn(const Similarity& gt_S_est, const std::vector<core::SE3d>& gt) {
  const core::SO3d Rinv = gt_S_est.rigid.so3().inverse();
  std::vector<core::SE3d> est;
  for (const core::SE3d& g : gt) {
    const core::Vec3 p = (Rinv * (g.translation() - gt_S_est.rigid.translation())) / gt_S_est.scale;
    est.push_back(core::SE3d(Rinv * g.so3(), p));
  }
  return est;
}

std::vector<core::SE3d> applied(const Similarity& S, const std::vector<core::SE3d>& est) {
  std::vector<core::SE3d> out;
  for (const auto& e : est) out.push_back(S * e);
  return out;
}

Similarity knownSimilarity(double scale) {
  Similarity S;
  S.scale = scale;
  core::Vec6 xi;
  xi << 3.0, -7.5, 1.25, 0.4, -1.1, 2.3;
  S.rigid = core::SE3d::exp(xi);
  return S;
}

TEST(Umeyama, RecoversAKnownSE3Exactly) {
  const auto gt = posesOf(testing::syntheticTrajectory(200));
  const Similarity truth = knownSimilarity(1.0);
  const auto est = expressedIn(truth, gt);
  const auto a = alignTrajectories(gt, est, AlignmentMode::kSE3);
  ASSERT_TRUE(a.ok()) << a.error().message;
  EXPECT_DOUBLE_EQ(a->gt_S_est.scale, 1.0);
  const core::SE3d d = core::between(truth.rigid, a->gt_S_est.rigid);
  EXPECT_LT(d.translation().norm(), 1e-9);
  EXPECT_LT(core::rotationAngle(d.so3()), 1e-12);
  EXPECT_TRUE(a->rotation_unique);
  const auto ate = computeAte(gt, applied(a->gt_S_est, est));
  ASSERT_TRUE(ate.ok());
  EXPECT_LT(ate->translation_m.max, 1e-9);
  EXPECT_LT(ate->rotation_deg.max, 1e-9);
}

TEST(Umeyama, RecoversAKnownSim3Exactly) {
  const auto gt = posesOf(testing::syntheticTrajectory(200));
  const Similarity truth = knownSimilarity(0.37);  // e.g. a monocular map at the wrong scale
  const auto est = expressedIn(truth, gt);
  const auto a = alignTrajectories(gt, est, AlignmentMode::kSim3);
  ASSERT_TRUE(a.ok()) << a.error().message;
  EXPECT_NEAR(a->gt_S_est.scale, 0.37, 1e-12);
  const core::SE3d d = core::between(truth.rigid, a->gt_S_est.rigid);
  EXPECT_LT(d.translation().norm(), 1e-9);
  EXPECT_LT(core::rotationAngle(d.so3()), 1e-12);
  const auto ate = computeAte(gt, applied(a->gt_S_est, est));
  ASSERT_TRUE(ate.ok());
  EXPECT_LT(ate->translation_m.rmse, 1e-9);
  EXPECT_LT(ate->rotation_deg.max, 1e-9);

  // SE(3) alignment of the same estimate cannot undo the scale: a large error remains.
  const auto rigid = alignTrajectories(gt, est, AlignmentMode::kSE3);
  ASSERT_TRUE(rigid.ok());
  const auto ate_rigid = computeAte(gt, applied(rigid->gt_S_est, est));
  EXPECT_GT(ate_rigid->translation_m.rmse, 1.0);
}

TEST(Umeyama, AgreesWithEigenOnNoisyPoints) {
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 0.05);
  const auto gt = posesOf(testing::syntheticTrajectory(300));
  const Similarity truth = knownSimilarity(2.5);
  auto est = expressedIn(truth, gt);
  Eigen::Matrix3Xd src(3, est.size());
  Eigen::Matrix3Xd dst(3, gt.size());
  std::vector<core::Vec3> src_v;
  std::vector<core::Vec3> dst_v;
  for (size_t i = 0; i < est.size(); ++i) {
    const core::Vec3 p = est[i].translation() + core::Vec3(noise(rng), noise(rng), noise(rng));
    src.col(static_cast<Eigen::Index>(i)) = p;
    dst.col(static_cast<Eigen::Index>(i)) = gt[i].translation();
    src_v.push_back(p);
    dst_v.push_back(gt[i].translation());
  }
  for (bool with_scale : {false, true}) {
    const Eigen::Matrix4d eigen = Eigen::umeyama(src, dst, with_scale);
    const auto ours = umeyama(src_v, dst_v, with_scale);
    ASSERT_TRUE(ours.ok());
    const Eigen::Matrix3d sR = ours->gt_S_est.scale * ours->gt_S_est.rigid.rotationMatrix();
    EXPECT_LT((sR - eigen.topLeftCorner<3, 3>()).cwiseAbs().maxCoeff(), 1e-9) << with_scale;
    EXPECT_LT((ours->gt_S_est.rigid.translation() - eigen.topRightCorner<3, 1>()).norm(), 1e-9);
  }
}

TEST(Umeyama, NeverReturnsAReflection) {
  // dst is the mirror image of src: the best proper rotation is what Umeyama's S matrix
  // (eq. 39) picks; an SVD without it would return det(R) = -1.
  std::vector<core::Vec3> src;
  std::vector<core::Vec3> dst;
  for (const auto& p : testing::syntheticTrajectory(100).poses) {
    src.push_back(p.world_T_body.translation());
    dst.push_back(core::Vec3(p.world_T_body.translation().x(), p.world_T_body.translation().y(),
                             -p.world_T_body.translation().z()));
  }
  Eigen::Matrix3Xd s(3, src.size());
  Eigen::Matrix3Xd d(3, dst.size());
  for (size_t i = 0; i < src.size(); ++i) {
    s.col(static_cast<Eigen::Index>(i)) = src[i];
    d.col(static_cast<Eigen::Index>(i)) = dst[i];
  }
  const auto a = umeyama(src, dst, true);
  ASSERT_TRUE(a.ok());
  EXPECT_NEAR(a->gt_S_est.rigid.rotationMatrix().determinant(), 1.0, 1e-12);
  const Eigen::Matrix4d eigen = Eigen::umeyama(s, d, true);
  EXPECT_LT((a->gt_S_est.scale * a->gt_S_est.rigid.rotationMatrix() - eigen.topLeftCorner<3, 3>())
                .cwiseAbs()
                .maxCoeff(),
            1e-9);
}

TEST(Umeyama, CollinearPointsAlignButFlagTheRotationAsNotUnique) {
  std::vector<core::Vec3> src;
  std::vector<core::Vec3> dst;
  for (int k = 0; k < 10; ++k) {
    src.push_back(core::Vec3(k, 0, 0));
    dst.push_back(core::Vec3(0, k + 1.0, 2.0));
  }
  const auto a = umeyama(src, dst, false);
  ASSERT_TRUE(a.ok());
  EXPECT_FALSE(a->rotation_unique);
  for (size_t i = 0; i < src.size(); ++i) {
    EXPECT_LT((a->gt_S_est * src[i] - dst[i]).norm(), 1e-12);
  }
}

TEST(Umeyama, TooFewOrDegeneratePairsAreErrors) {
  const std::vector<core::Vec3> two = {core::Vec3(0, 0, 0), core::Vec3(1, 0, 0)};
  auto r = umeyama(two, two, false);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("at least 3"), std::string::npos) << r.error().message;

  const std::vector<core::Vec3> same(5, core::Vec3(1, 2, 3));
  r = umeyama(same, same, true);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("scale is undefined"), std::string::npos);

  std::vector<core::Vec3> nan = same;
  nan[2].x() = std::nan("");
  EXPECT_FALSE(umeyama(nan, same, false).ok());
  EXPECT_FALSE(umeyama(same, two, false).ok());
  EXPECT_FALSE(parseAlignmentMode("sim2").ok());
  EXPECT_EQ(*parseAlignmentMode("sim3"), AlignmentMode::kSim3);
}

TEST(Umeyama, NoAlignmentIsTheIdentity) {
  const auto gt = posesOf(testing::syntheticTrajectory(2));
  const auto a = alignTrajectories(gt, gt, AlignmentMode::kNone);
  ASSERT_TRUE(a.ok());
  EXPECT_EQ(a->gt_S_est.scale, 1.0);
  EXPECT_EQ(a->gt_S_est.rigid.translation(), core::Vec3::Zero());
  EXPECT_FALSE(alignTrajectories({}, {}, AlignmentMode::kNone).ok());
}

TEST(FirstPoseAlignment, PutsTheFirstEstimateOnTheFirstGroundTruthPose) {
  const auto gt = posesOf(testing::syntheticTrajectory(20));
  core::Vec6 xi;
  xi << 3.0, -1.0, 0.5, 0.2, -0.1, 1.3;
  const core::SE3d est_T_gt = core::SE3d::exp(xi);
  std::vector<core::SE3d> est;
  for (const auto& p : gt) est.push_back(est_T_gt * p);
  const auto a = alignTrajectories(gt, est, AlignmentMode::kFirstPose);
  ASSERT_TRUE(a.ok()) << a.error().message;
  EXPECT_EQ(a->mode, AlignmentMode::kFirstPose);
  EXPECT_TRUE(a->gt_S_est.rigid.matrix().isApprox(est_T_gt.inverse().matrix(), 1e-12));
  for (size_t i = 0; i < gt.size(); ++i) {
    EXPECT_TRUE((a->gt_S_est * est[i]).matrix().isApprox(gt[i].matrix(), 1e-9)) << i;
  }
  EXPECT_EQ(*parseAlignmentMode("first"), AlignmentMode::kFirstPose);
  EXPECT_STREQ(toString(AlignmentMode::kFirstPose), "first");
}

}  // namespace
}  // namespace evermap::eval
