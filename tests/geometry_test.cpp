// core/geometry: group properties, conventions, Jacobians against numerical derivatives,
// and the covariance propagation of paper eq. (6)-(7) against Monte Carlo.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "core/geometry/se2.h"
#include "core/geometry/se3.h"

namespace evermap::core {
namespace {

constexpr double kPi = std::numbers::pi;

std::vector<Vec6> sampleTangents() {
  std::mt19937 rng(7);
  std::normal_distribution<double> n(0.0, 1.0);
  std::vector<Vec6> out = {Vec6::Zero()};
  Vec6 tiny;
  tiny << 1e-9, -2e-9, 3e-9, 1e-10, -1e-10, 2e-10;
  out.push_back(tiny);
  for (int i = 0; i < 20; ++i) {
    Vec6 xi;
    for (int k = 0; k < 6; ++k) xi[k] = n(rng);
    // Rotation angles stay below pi, where log is the inverse of exp.
    if (xi.tail<3>().norm() > 3.0) xi.tail<3>() *= 3.0 / xi.tail<3>().norm();
    out.push_back(xi);
  }
  Vec6 near_pi;
  near_pi << 0.3, -0.2, 1.0, 0.0, 0.0, kPi - 1e-4;
  out.push_back(near_pi);
  return out;
}

// Right-perturbation numerical Jacobian of f: SE3 -> SE3 at x.
template <typename F>
Mat6 numericJacobian(F f, const SE3d& x) {
  const double h = 1e-6;
  const SE3d fx = f(x);
  Mat6 J;
  for (int i = 0; i < 6; ++i) {
    Vec6 d = Vec6::Zero();
    d[i] = h;
    const Vec6 plus = (fx.inverse() * f(x * SE3d::exp(d))).log();
    const Vec6 minus = (fx.inverse() * f(x * SE3d::exp(-d))).log();
    J.col(i) = (plus - minus) / (2.0 * h);
  }
  return J;
}

TEST(SO3, QuaternionIsHamiltonAndStoredWxyzWhenSerialised) {
  // A quarter turn about z maps x to y (active rotation, Hamilton product).
  const SO3d R = SO3d::exp(Vec3(0.0, 0.0, kPi / 2));
  EXPECT_TRUE((R * Vec3::UnitX()).isApprox(Vec3::UnitY(), 1e-12));
  const Eigen::Quaterniond& q = R.quaternion();
  EXPECT_NEAR(q.w(), std::cos(kPi / 4), 1e-12);
  EXPECT_NEAR(q.z(), std::sin(kPi / 4), 1e-12);
  // Composition order: (A * B) * v == A * (B * v).
  const SO3d A = SO3d::exp(Vec3(0.1, 0.2, 0.3));
  const SO3d B = SO3d::exp(Vec3(-0.4, 0.5, 0.6));
  EXPECT_TRUE(((A * B) * Vec3(1, 2, 3)).isApprox(A * (B * Vec3(1, 2, 3)), 1e-12));
}

TEST(SO3, RollPitchYawRoundTripsAndFollowsZYX) {
  const SO3d R = SO3d::fromRollPitchYaw(0.1, -0.2, 2.5);
  const Vec3 rpy = R.rollPitchYaw();
  EXPECT_NEAR(rpy.x(), 0.1, 1e-12);
  EXPECT_NEAR(rpy.y(), -0.2, 1e-12);
  EXPECT_NEAR(rpy.z(), 2.5, 1e-12);
  const Mat3 expected =
      (Eigen::AngleAxisd(2.5, Vec3::UnitZ()) * Eigen::AngleAxisd(-0.2, Vec3::UnitY()) *
       Eigen::AngleAxisd(0.1, Vec3::UnitX()))
          .toRotationMatrix();
  EXPECT_TRUE(R.matrix().isApprox(expected, 1e-12));
}

TEST(SO3, HatAndVeeAreInverseAndHatIsCrossProduct) {
  const Vec3 a(1, -2, 3);
  const Vec3 b(0.5, 4, -1);
  EXPECT_TRUE((hat(a) * b).isApprox(a.cross(b)));
  EXPECT_TRUE(vee(hat(a)).isApprox(a));
}

TEST(SO3, RightJacobianMatchesNumericalDerivativeOfExp) {
  for (const Vec6& xi : sampleTangents()) {
    const Vec3 w = xi.tail<3>();
    Mat3 J;
    const double h = 1e-6;
    for (int i = 0; i < 3; ++i) {
      Vec3 d = Vec3::Zero();
      d[i] = h;
      J.col(i) = ((SO3d::exp(w).inverse() * SO3d::exp(w + d)).log() -
                  (SO3d::exp(w).inverse() * SO3d::exp(w - d)).log()) /
                 (2 * h);
    }
    EXPECT_TRUE(J.isApprox(SO3d::rightJacobian(w), 1e-6)) << w.transpose();
    if (w.norm() < kPi - 1e-2) {
      EXPECT_TRUE((SO3d::rightJacobian(w) * SO3d::rightJacobianInverse(w))
                      .isApprox(Mat3::Identity(), 1e-9));
    }
  }
}

TEST(SE3, ExpLogRoundTrip) {
  for (const Vec6& xi : sampleTangents()) {
    const SE3d T = SE3d::exp(xi);
    EXPECT_TRUE(T.log().isApprox(xi, 1e-8) || (T.log() - xi).norm() < 1e-12)
        << xi.transpose() << " -> " << T.log().transpose();
    EXPECT_TRUE(SE3d::exp(T.log()).matrix().isApprox(T.matrix(), 1e-10));
  }
}

TEST(SE3, TangentIsTranslationFirst) {
  Vec6 xi = Vec6::Zero();
  xi[0] = 1.5;  // pure translation along x
  const SE3d T = SE3d::exp(xi);
  EXPECT_TRUE(T.translation().isApprox(Vec3(1.5, 0, 0)));
  EXPECT_NEAR(rotationAngle(T.so3()), 0.0, 1e-15);
}

TEST(SE3, InverseAndCompositionAreConsistent) {
  for (const Vec6& xi : sampleTangents()) {
    const SE3d T = SE3d::exp(xi);
    EXPECT_TRUE((T * T.inverse()).matrix().isApprox(Mat4::Identity(), 1e-12));
    EXPECT_TRUE((T.matrix() * T.inverse().matrix()).isApprox(Mat4::Identity(), 1e-12));
    const Vec3 p(0.3, -1.0, 2.0);
    EXPECT_TRUE((T * p).isApprox((T.matrix() * p.homogeneous()).head<3>(), 1e-12));
  }
}

TEST(SE3, AdjointConjugatesTangentVectors) {
  const auto xs = sampleTangents();
  for (size_t i = 0; i + 1 < xs.size(); ++i) {
    const SE3d T = SE3d::exp(xs[i]);
    const Vec6 d = 0.3 * xs[i + 1];
    const SE3d lhs = T * SE3d::exp(d) * T.inverse();
    const SE3d rhs = SE3d::exp(T.adjoint() * d);
    EXPECT_TRUE(lhs.matrix().isApprox(rhs.matrix(), 1e-9));
  }
}

TEST(SE3, RightJacobianMatchesNumericalDerivativeOfExp) {
  for (const Vec6& xi : sampleTangents()) {
    if (xi.tail<3>().norm() > kPi - 1e-2) continue;
    Mat6 J;
    const double h = 1e-6;
    const SE3d T = SE3d::exp(xi);
    for (int i = 0; i < 6; ++i) {
      Vec6 d = Vec6::Zero();
      d[i] = h;
      J.col(i) =
          ((T.inverse() * SE3d::exp(xi + d)).log() - (T.inverse() * SE3d::exp(xi - d)).log()) /
          (2 * h);
    }
    EXPECT_TRUE(J.isApprox(SE3d::rightJacobian(xi), 1e-6)) << xi.transpose();
    EXPECT_TRUE((SE3d::rightJacobian(xi) * SE3d::rightJacobianInverse(xi))
                    .isApprox(Mat6::Identity(), 1e-8));
  }
}

TEST(SE3, CompoundingJacobiansMatchNumericalDerivatives) {
  const auto xs = sampleTangents();
  for (size_t i = 0; i + 1 < xs.size(); ++i) {
    const SE3d a = SE3d::exp(xs[i]);
    const SE3d b = SE3d::exp(xs[i + 1]);
    Mat6 Ja, Jb, Ji, Jba, Jbb;
    compose(a, b, &Ja, &Jb);
    inverse(a, &Ji);
    between(a, b, &Jba, &Jbb);
    EXPECT_TRUE(Ja.isApprox(numericJacobian([&](const SE3d& x) { return x * b; }, a), 1e-6));
    EXPECT_TRUE(Jb.isApprox(numericJacobian([&](const SE3d& x) { return a * x; }, b), 1e-6));
    EXPECT_TRUE(Ji.isApprox(numericJacobian([](const SE3d& x) { return x.inverse(); }, a), 1e-6));
    EXPECT_TRUE(
        Jba.isApprox(numericJacobian([&](const SE3d& x) { return x.inverse() * b; }, a), 1e-6));
    EXPECT_TRUE(
        Jbb.isApprox(numericJacobian([&](const SE3d& x) { return a.inverse() * x; }, b), 1e-6));
  }
}

// Eq. (7) against the covariance of sampled compounds, for small noise.
TEST(SE3, CompoundedCovarianceMatchesMonteCarloWithinFivePercent) {
  Vec6 x12, x23;
  x12 << 1.0, 0.2, -0.1, 0.1, -0.2, 0.6;
  x23 << 0.5, -0.7, 0.3, -0.3, 0.1, 1.1;
  UncertainPose z12{SE3d::exp(x12), Mat6::Zero()};
  UncertainPose z23{SE3d::exp(x23), Mat6::Zero()};
  Vec6 s12, s23;
  s12 << 0.02, 0.03, 0.01, 0.004, 0.006, 0.01;
  s23 << 0.03, 0.01, 0.02, 0.008, 0.003, 0.005;
  z12.covariance = s12.cwiseAbs2().asDiagonal();
  z23.covariance = s23.cwiseAbs2().asDiagonal();
  z12.covariance(0, 5) = z12.covariance(5, 0) = 0.5 * s12[0] * s12[5];  // some correlation

  const UncertainPose z13 = compound(z12, z23);

  std::mt19937 rng(42);
  std::normal_distribution<double> n(0.0, 1.0);
  const Eigen::LLT<Mat6> L12(z12.covariance);
  const Eigen::LLT<Mat6> L23(z23.covariance);
  const int N = 200000;
  Mat6 sum = Mat6::Zero();
  Vec6 mean = Vec6::Zero();
  std::vector<Vec6> samples(N);
  for (int k = 0; k < N; ++k) {
    Vec6 e1, e2;
    for (int i = 0; i < 6; ++i) {
      e1[i] = n(rng);
      e2[i] = n(rng);
    }
    const SE3d a = z12.mean * SE3d::exp(L12.matrixL() * e1);
    const SE3d b = z23.mean * SE3d::exp(L23.matrixL() * e2);
    samples[k] = (z13.mean.inverse() * (a * b)).log();
    mean += samples[k];
  }
  mean /= N;
  for (const Vec6& s : samples) sum += (s - mean) * (s - mean).transpose();
  const Mat6 mc = sum / (N - 1);
  const double rel = (mc - z13.covariance).norm() / z13.covariance.norm();
  EXPECT_LT(rel, 0.05) << "Monte Carlo:\n" << mc << "\neq. (7):\n" << z13.covariance;
  // Diagonal entries one by one, too.
  for (int i = 0; i < 6; ++i) {
    EXPECT_NEAR(mc(i, i), z13.covariance(i, i), 0.05 * z13.covariance(i, i)) << "entry " << i;
  }
}

TEST(SE3, InvertedCovarianceMatchesMonteCarlo) {
  Vec6 x;
  x << 2.0, -1.0, 0.5, 0.3, 0.2, -0.8;
  UncertainPose z{SE3d::exp(x), Mat6::Zero()};
  Vec6 s;
  s << 0.02, 0.02, 0.01, 0.01, 0.005, 0.01;
  z.covariance = s.cwiseAbs2().asDiagonal();
  const UncertainPose zi = invert(z);
  std::mt19937 rng(3);
  std::normal_distribution<double> n(0.0, 1.0);
  const int N = 100000;
  Mat6 acc = Mat6::Zero();
  for (int k = 0; k < N; ++k) {
    Vec6 e;
    for (int i = 0; i < 6; ++i) e[i] = s[i] * n(rng);
    const Vec6 d = (zi.mean.inverse() * (z.mean * SE3d::exp(e)).inverse()).log();
    acc += d * d.transpose();
  }
  const Mat6 mc = acc / N;
  EXPECT_LT((mc - zi.covariance).norm() / zi.covariance.norm(), 0.05);
}

TEST(SE2, ComposeInverseAndExpLogAgree) {
  const SE2d a(1.0, 2.0, 0.7);
  const SE2d b(-0.5, 0.3, -2.9);
  const SE2d ab = a * b;
  const SE2d back = a.inverse() * ab;
  EXPECT_NEAR(back.x(), b.x(), 1e-12);
  EXPECT_NEAR(back.y(), b.y(), 1e-12);
  EXPECT_NEAR(back.theta(), b.theta(), 1e-12);
  const Eigen::Vector3d xi = a.log();
  const SE2d a2 = SE2d::exp(xi);
  EXPECT_NEAR(a2.x(), a.x(), 1e-12);
  EXPECT_NEAR(a2.y(), a.y(), 1e-12);
  EXPECT_NEAR(a2.theta(), a.theta(), 1e-12);
  EXPECT_NEAR(wrapAngle(3 * kPi), kPi, 1e-12);
  EXPECT_NEAR(wrapAngle(-kPi), kPi, 1e-12);
}

TEST(SE2, SscJacobiansMatchNumericalDerivatives) {
  const SE2d a(1.0, 2.0, 0.7);
  const SE2d b(-0.5, 0.3, -2.0);
  Eigen::Matrix3d Ja, Jb, Ji, Jba, Jbb;
  compose(a, b, &Ja, &Jb);
  inverse(a, &Ji);
  between(a, b, &Jba, &Jbb);
  auto num = [](auto f, const SE2d& x) {
    Eigen::Matrix3d J;
    const double h = 1e-6;
    for (int i = 0; i < 3; ++i) {
      Eigen::Vector3d d = Eigen::Vector3d::Zero();
      d[i] = h;
      const Eigen::Vector3d v = x.vector();
      const SE2d p(v.x() + d.x(), v.y() + d.y(), v.z() + d.z());
      const SE2d m(v.x() - d.x(), v.y() - d.y(), v.z() - d.z());
      Eigen::Vector3d diff = f(p).vector() - f(m).vector();
      diff.z() = wrapAngle(diff.z());
      J.col(i) = diff / (2 * h);
    }
    return J;
  };
  EXPECT_TRUE(Ja.isApprox(num([&](const SE2d& x) { return x * b; }, a), 1e-6));
  EXPECT_TRUE(Jb.isApprox(num([&](const SE2d& x) { return a * x; }, b), 1e-6));
  EXPECT_TRUE(Ji.isApprox(num([](const SE2d& x) { return x.inverse(); }, a), 1e-6));
  EXPECT_TRUE(Jba.isApprox(num([&](const SE2d& x) { return x.inverse() * b; }, a), 1e-6));
  EXPECT_TRUE(Jbb.isApprox(num([&](const SE2d& x) { return a.inverse() * x; }, b), 1e-6));
}

TEST(SE2, PlanarProjectionKeepsYawAndGridSeparatesHeadings) {
  const SE3d T(SO3d::fromRollPitchYaw(0.05, -0.03, 1.2), Vec3(3.2, -4.7, 1.0));
  const SE2d p = toPlanar(T);
  EXPECT_NEAR(p.x(), 3.2, 1e-12);
  EXPECT_NEAR(p.y(), -4.7, 1e-12);
  EXPECT_NEAR(p.theta(), 1.2, 2e-3);  // small roll/pitch barely move the heading
  PlanarGrid grid{.cell_size_m = 2.0, .heading_bins = 4};
  const PlanarCell c = grid.cellOf(SE2d(3.2, -4.7, 0.1), 2);
  EXPECT_EQ(c.ix, 1);
  EXPECT_EQ(c.iy, -3);
  EXPECT_EQ(c.floor, 2);
  EXPECT_FALSE(c == grid.cellOf(SE2d(3.2, -4.7, 0.1 + kPi), 2));
  EXPECT_TRUE(c == grid.cellOf(SE2d(3.9, -4.1, 0.3), 2));
  EXPECT_FALSE(c == grid.cellOf(SE2d(3.2, -4.7, 0.1), 3));
}

}  // namespace
}  // namespace evermap::core
