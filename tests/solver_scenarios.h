#pragma once
// Small pose graphs with known answers for the solver tests: a planar path of squares and a
// 3-D helix-like path, with odometry and loop closures measured from the truth with optional
// noise, and the factor of one measurement.

#include <random>
#include <tuple>
#include <vector>

#include <Eigen/Core>
#include <gtest/gtest.h>

#include "core/geometry/se2.h"
#include "core/geometry/se3.h"
#include "core/solver/graph_problem.h"
#include "core/solver/incremental_solver.h"
#include "core/solver/normal_equations.h"
#include "core/solver/pose_factors.h"
#include "core/solver/pose_graph.h"
#include "core/solver/values.h"

namespace evermap::solver::testing {

using core::SE2d;
using core::SE3d;

// A closed square path of n poses per side with loop closures every `loop_every` poses,
// measured from the truth with optional noise.
struct Scenario {
  std::vector<PoseValue> truth;
  std::vector<std::tuple<int, int, PoseValue>> edges;  // from, to, measurement
};

inline PoseValue poseValue(const SE2d& p) { return PoseValue::planar(p); }
inline PoseValue poseValue(const SE3d& p) { return PoseValue::spatial(p); }

// n poses from the identity, pose i + 1 = next(pose i, i); odometry between neighbours and a
// loop closure from pose i - loop_span to pose i every loop_step poses, each measured as
// noisy(true relative pose, nd, rng).
template <typename Pose, typename Next, typename Noisy>
Scenario pathScenario(int n, double noise, unsigned seed, int loop_span, int loop_step, Next next,
                      Noisy noisy) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> nd(0.0, noise);
  Scenario s;
  std::vector<Pose> truth;
  Pose p;
  for (int i = 0; i < n; ++i) {
    truth.push_back(p);
    s.truth.push_back(poseValue(p));
    p = next(p, i);
  }
  auto measure = [&](int a, int b) {
    return poseValue(noisy(truth[a].inverse() * truth[b], nd, rng));
  };
  for (int i = 1; i < n; ++i) s.edges.emplace_back(i - 1, i, measure(i - 1, i));
  for (int i = loop_span; i < n; i += loop_step) {
    s.edges.emplace_back(i - loop_span, i, measure(i - loop_span, i));
  }
  return s;
}

inline Scenario planarScenario(int n, double noise, unsigned seed) {
  return pathScenario<SE2d>(
      n, noise, seed, 7, 3,
      [](const SE2d& p, int i) {
        return p * SE2d(1.0, 0.0, (i % 5 == 4) ? 1.5707963267948966 : 0.05);
      },
      [](const SE2d& z, std::normal_distribution<double>& nd, std::mt19937& rng) {
        return SE2d(z.x() + nd(rng), z.y() + nd(rng), z.theta() + nd(rng));
      });
}

inline Scenario spatialScenario(int n, double noise, unsigned seed) {
  return pathScenario<SE3d>(
      n, noise, seed, 6, 2,
      [](const SE3d& p, int i) {
        Eigen::Matrix<double, 6, 1> step;
        step << 1.0, 0.1, 0.05, 0.05, 0.1, (i % 4 == 3) ? 1.2 : 0.1;
        return p * SE3d::exp(step);
      },
      [](const SE3d& z, std::normal_distribution<double>& nd, std::mt19937& rng) {
        Eigen::Matrix<double, 6, 1> e;
        for (int k = 0; k < 6; ++k) e[k] = nd(rng);
        return z * SE3d::exp(e);
      });
}

inline FactorPtr edgeFactor(int a, int b, const PoseValue& z) {
  if (z.kind == PoseKind::kSE2) {
    return std::make_shared<RelativePose2Factor>(a, b, z.se2,
                                                 10.0 * Eigen::MatrixXd::Identity(3, 3));
  }
  return std::make_shared<RelativePose3Factor>(a, b, z.se3, 10.0 * Eigen::MatrixXd::Identity(6, 6));
}

// The request that adds pose i of the scenario to `inc`: pose 0 with its anchor, any other
// chained from the estimate of i - 1, with the factors of the edges that end at it.
inline UpdateRequest poseRequest(const Scenario& s, const IncrementalSolver& inc, int i) {
  UpdateRequest r;
  if (i == 0) {
    r.new_variables.emplace_back(0, s.truth[0]);
    r.new_factors.push_back(makeAnchorFactor(0, s.truth[0].kind == PoseKind::kSE2 ? 2 : 3));
    return r;
  }
  for (const auto& [a, b, z] : s.edges) {
    if (b != i) continue;
    if (a == i - 1) r.new_variables.emplace_back(i, compose(inc.estimate(a), z));
    r.new_factors.push_back(edgeFactor(a, b, z));
  }
  return r;
}

// Adds poses 0 .. n-1 of `s` to `inc`, one update each; a failed update fails the test
// (call it inside ASSERT_NO_FATAL_FAILURE).
inline void addPoses(IncrementalSolver& inc, const Scenario& s, int n) {
  for (int i = 0; i < n; ++i) ASSERT_TRUE(inc.update(poseRequest(s, inc, i)).ok()) << "pose " << i;
}

// Incremental options without scheduled batch steps: R changes by Householder updates only.
inline IncrementalOptions withoutBatchSteps() {
  IncrementalOptions o;
  o.batch_every = 0;
  return o;
}

// The Gauss-Newton system of the graph at its values, dense: H (n x n) and the right-hand
// side, for checks against a dense inverse or solve.
inline Eigen::MatrixXd denseHessian(const PoseGraph& g, Eigen::VectorXd* rhs) {
  const BlockPattern pat = buildPattern(g);
  std::vector<double> H(pat.nnz());
  assembleNormalEquations(g, g.values(), pat, H.data(), rhs);
  const int n = pat.scalarSize();
  Eigen::MatrixXd Hd(n, n);
  for (int c = 0; c < n; ++c) {
    Eigen::VectorXd e = Eigen::VectorXd::Zero(n);
    e[c] = 1.0;
    Eigen::VectorXd col = Eigen::VectorXd::Zero(n);
    pat.multiplyAdd(H.data(), e, &col);
    Hd.col(c) = col;
  }
  return Hd;
}

}  // namespace evermap::solver::testing
