// core/solver factors: every analytic Jacobian against central differences through the
// solver's retraction, residual conventions on known cases, robust kernels against their
// definitions.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include "core/solver/pose_factors.h"

#include "tests/solver_test_util.h"

namespace evermap::solver {
namespace {

using testing::jacobianError;

using core::SE2d;
using core::SE3d;

std::mt19937 rng(42);

SE2d randomSE2() {
  std::uniform_real_distribution<double> u(-2.0, 2.0);
  std::uniform_real_distribution<double> a(-2.5, 2.5);
  return SE2d(u(rng), u(rng), a(rng));
}

SE3d randomSE3(double max_angle = 1.2) {
  std::normal_distribution<double> n(0.0, 1.0);
  core::Vec3 w(n(rng), n(rng), n(rng));
  w *= max_angle / std::max(1.0, w.norm());
  return SE3d(core::SO3d::exp(w), core::Vec3(n(rng), n(rng), n(rng)));
}

Eigen::MatrixXd eye(int n) { return Eigen::MatrixXd::Identity(n, n); }

TEST(SolverFactors, RelativePose2JacobiansMatchNumericalDerivatives) {
  for (auto conv :
       {RelativePose2Factor::Convention::kIsam, RelativePose2Factor::Convention::kG2o}) {
    for (int k = 0; k < 20; ++k) {
      RelativePose2Factor f(0, 1, randomSE2(), eye(3), conv);
      EXPECT_LT(jacobianError(f, {PoseValue::planar(randomSE2()), PoseValue::planar(randomSE2())}),
                1e-7);
    }
  }
}

TEST(SolverFactors, RelativePose3JacobiansMatchNumericalDerivatives) {
  for (auto conv : {RelativePose3Factor::Convention::kLog, RelativePose3Factor::Convention::kG2o,
                    RelativePose3Factor::Convention::kIsamEuler}) {
    for (int k = 0; k < 20; ++k) {
      const SE3d a = randomSE3();
      // Keep the predicted relative pose near the measurement (pitch away from ±π/2 for the
      // Euler convention, angle below π for log and quaternions).
      const SE3d z = randomSE3(0.8);
      const SE3d b =
          a * z *
          SE3d::exp(
              (Eigen::Matrix<double, 6, 1>() << 0.1, -0.2, 0.05, 0.1, -0.05, 0.08).finished());
      RelativePose3Factor f(0, 1, z, eye(6), conv);
      EXPECT_LT(jacobianError(f, {PoseValue::spatial(a), PoseValue::spatial(b)}), 1e-6)
          << "convention " << static_cast<int>(conv);
    }
  }
}

TEST(SolverFactors, ChordalJacobiansMatchNumericalDerivatives) {
  for (int k = 0; k < 20; ++k) {
    ChordalRelativePose2Factor f2(0, 1, randomSE2(), 3.0, 2.0);
    EXPECT_LT(jacobianError(f2, {PoseValue::planar(randomSE2()), PoseValue::planar(randomSE2())}),
              1e-7);
    ChordalRelativePose3Factor f3(0, 1, randomSE3(), 3.0, 2.0);
    EXPECT_LT(jacobianError(f3, {PoseValue::spatial(randomSE3()), PoseValue::spatial(randomSE3())}),
              1e-7);
  }
}

TEST(SolverFactors, PriorAndPartialPriorJacobiansMatchNumericalDerivatives) {
  for (int k = 0; k < 20; ++k) {
    PosePrior2Factor p2(0, randomSE2(), eye(3));
    EXPECT_LT(jacobianError(p2, {PoseValue::planar(randomSE2())}), 1e-7);
    const SE3d m = randomSE3(0.5);
    PosePrior3Factor p3(0, m, eye(6));
    EXPECT_LT(jacobianError(p3, {PoseValue::spatial(m * randomSE3(0.5))}), 1e-6);
    RollPitchFactor rp(0, 0.1, -0.2, eye(2));
    EXPECT_LT(jacobianError(rp, {PoseValue::spatial(randomSE3(0.9))}), 1e-6);
    HeightFactor h(0, 1.5, 0.1);
    EXPECT_LT(jacobianError(h, {PoseValue::spatial(randomSE3())}), 1e-7);
  }
}

TEST(SolverFactors, ResidualsVanishAtTheMeasurement) {
  const SE3d a = randomSE3();
  const SE3d z = randomSE3(0.7);
  const PoseValue pa = PoseValue::spatial(a);
  const PoseValue pb = PoseValue::spatial(a * z);
  const PoseValue* x[2] = {&pa, &pb};
  for (auto conv : {RelativePose3Factor::Convention::kLog, RelativePose3Factor::Convention::kG2o,
                    RelativePose3Factor::Convention::kIsamEuler}) {
    RelativePose3Factor f(0, 1, z, eye(6), conv);
    Eigen::VectorXd r(6);
    f.evaluate(x, r.data(), nullptr);
    EXPECT_LT(r.norm(), 1e-12);
  }
  ChordalRelativePose3Factor c(0, 1, z, 2.0, 3.0);
  Eigen::VectorXd r(12);
  c.evaluate(x, r.data(), nullptr);
  EXPECT_LT(r.norm(), 1e-12);
}

TEST(SolverFactors, IsamResidualDiffersFromG2oOnlyByTheMeasurementRotation) {
  const SE2d z(1.0, 0.5, 0.7);
  const PoseValue a = PoseValue::planar(SE2d(0.3, -0.2, 0.4));
  const PoseValue b = PoseValue::planar(SE2d(1.5, 0.9, 1.0));
  const PoseValue* x[2] = {&a, &b};
  Eigen::Vector3d ri, rg;
  RelativePose2Factor(0, 1, z, eye(3), RelativePose2Factor::Convention::kIsam)
      .evaluate(x, ri.data(), nullptr);
  RelativePose2Factor(0, 1, z, eye(3), RelativePose2Factor::Convention::kG2o)
      .evaluate(x, rg.data(), nullptr);
  EXPECT_TRUE((z.rotationMatrix().transpose() * ri.head<2>()).isApprox(rg.head<2>(), 1e-12));
  EXPECT_NEAR(ri[2], rg[2], 1e-12);
}

TEST(SolverFactors, YawPitchRollInvertsTheZyxConvention) {
  const core::Mat3 R = core::SO3d::fromRollPitchYaw(0.3, -0.4, 2.0).matrix();
  const core::Vec3 ypr = yawPitchRoll(R);
  EXPECT_NEAR(ypr[0], 2.0, 1e-12);
  EXPECT_NEAR(ypr[1], -0.4, 1e-12);
  EXPECT_NEAR(ypr[2], 0.3, 1e-12);
}

TEST(SolverFactors, RobustKernelWeightIsTheDerivativeOfTheCost) {
  for (KernelType t : {KernelType::kPseudoHuber, KernelType::kCauchy, KernelType::kDcs}) {
    RobustKernel k{t, 2.0};
    for (double s : {0.1, 1.0, 3.0, 10.0, 100.0}) {
      const double h = 1e-6 * s;
      const double numeric = (k.cost(s + h) - k.cost(s - h)) / (2 * h);
      EXPECT_NEAR(k.weight(s), numeric, 1e-6) << k.name() << " at " << s;
    }
    EXPECT_NEAR(k.cost(1e-9), 1e-9, 1e-12) << "kernels are quadratic near zero";
  }
}

TEST(SolverFactors, GncSurrogateWeightIsItsDerivativeAndItTendsToTruncatedLeastSquares) {
  for (double mu : {0.01, 0.3, 1.0, 20.0}) {
    RobustKernel k{KernelType::kGncTls, 9.0, mu};
    for (double s : {0.1, 1.0, 5.0, 9.5, 30.0, 200.0, 5000.0}) {
      const double h = 1e-6 * s;
      const double numeric = (k.cost(s + h) - k.cost(s - h)) / (2 * h);
      EXPECT_NEAR(k.weight(s), numeric, 1e-5) << "mu " << mu << " at " << s;
      EXPECT_GE(k.weight(s), 0.0);
      EXPECT_LE(k.weight(s), 1.0);
    }
  }
  // Large μ: min(s, c̄²) away from the threshold. Small μ: in the residual r = √s the
  // surrogate is r² near zero, then 2c̄√(μ(μ+1)) r − μ(c̄² + r²), whose curvature −2μ
  // vanishes as μ → 0 (ℓ1-like: the paper's convex limit).
  const RobustKernel tls{KernelType::kGncTls, 9.0, 1e6};
  EXPECT_NEAR(tls.cost(4.0), 4.0, 1e-9);
  EXPECT_NEAR(tls.cost(40.0), 9.0, 1e-9);
  const RobustKernel convex{KernelType::kGncTls, 9.0, 1e-4};
  for (double r = 0.01; r < 300.0; r *= 1.3) {
    const double h = 1e-3 * r;
    const double second =
        convex.cost((r + h) * (r + h)) - 2.0 * convex.cost(r * r) + convex.cost((r - h) * (r - h));
    EXPECT_GE(second / (h * h), -2.0 * 1e-4 - 1e-6) << "curvature below −2μ at r = " << r;
    EXPECT_LE(convex.cost(r * r), r * r + 1e-12);
  }
  EXPECT_GT(convex.weight(1000.0), 0.0);
  const RobustKernel beyond{KernelType::kGncTls, 9.0, 1.0};
  EXPECT_EQ(beyond.weight(1000.0), 0.0) << "beyond c̄²(μ+1)/μ the weight is zero";
}

TEST(SolverFactors, ChiSquareQuantileMatchesTables) {
  // 0.99 quantiles: 11.345 (3 dof), 16.812 (6), 26.217 (12).
  EXPECT_NEAR(chiSquareQuantile(3, 0.99), 11.345, 0.1);
  EXPECT_NEAR(chiSquareQuantile(6, 0.99), 16.812, 0.1);
  EXPECT_NEAR(chiSquareQuantile(12, 0.99), 26.217, 0.1);
}

TEST(SolverFactors, DcsIsQuadraticUpToPhiAndBoundedBeyond) {
  const RobustKernel k{KernelType::kDcs, 5.0};
  EXPECT_DOUBLE_EQ(k.cost(4.0), 4.0);
  EXPECT_DOUBLE_EQ(k.weight(4.0), 1.0);
  EXPECT_LT(k.cost(1e6), 4.0 * 5.0 + 1e-9);  // tends to Φ·(1 + …) ≤ 4Φ
  EXPECT_LT(k.weight(1e6), 1e-9);
}

TEST(SolverFactors, ParsesKernelNamesAndRejectsBadOnes) {
  auto k = parseRobustKernel("cauchy:2.5");
  ASSERT_TRUE(k.ok());
  EXPECT_EQ(k->type, KernelType::kCauchy);
  EXPECT_DOUBLE_EQ(k->parameter, 2.5);
  auto gnc = parseRobustKernel("gnc");
  ASSERT_TRUE(gnc.ok());
  EXPECT_EQ(gnc->type, KernelType::kGncTls);
  EXPECT_EQ(gnc->parameter, 0.0) << "threshold chosen per factor dimension";
  EXPECT_FALSE(parseRobustKernel("tukey").ok());
  EXPECT_FALSE(parseRobustKernel("dcs:-1").ok());
  EXPECT_FALSE(parseRobustKernel("dcs:abc").ok());
}

TEST(SolverFactors, SqrtInformationRejectsNanAndIndefiniteMatrices) {
  Eigen::MatrixXd I = eye(3);
  EXPECT_TRUE(sqrtInformationFromInformation(I, "x").ok());
  I(1, 1) = -1.0;
  auto bad = sqrtInformationFromInformation(I, "edge.g2o:7");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("edge.g2o:7"), std::string::npos);
  EXPECT_NE(bad.error().message.find("positive definite"), std::string::npos);
  I = eye(3);
  I(0, 2) = std::nan("");
  EXPECT_FALSE(sqrtInformationFromInformation(I, "x").ok());
  Eigen::MatrixXd S = eye(3);
  S(1, 1) = 0.0;
  EXPECT_FALSE(checkSqrtInformation(S, "x").ok());
}

}  // namespace
}  // namespace evermap::solver
