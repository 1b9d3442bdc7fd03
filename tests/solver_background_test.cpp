// The incremental solver's background batch steps (IncrementalOptions::background_batch_lag)
// and the marginals read straight from its factor (Marginals::jointOf).

#include <gtest/gtest.h>

#include <chrono>
#include <random>
#include <thread>

#include <Eigen/Dense>

#include "core/solver/batch_solver.h"
#include "core/solver/graph_problem.h"
#include "core/solver/incremental_solver.h"
#include "core/solver/marginals.h"
#include "core/solver/normal_equations.h"
#include "core/solver/pose_factors.h"
#include "solver_scenarios.h"

namespace evermap::solver {
namespace {

using core::SE3d;

using testing::addPoses;
using testing::edgeFactor;
using testing::poseRequest;
using testing::Scenario;
using testing::spatialScenario;
using testing::withoutBatchSteps;

// The largest difference between the solver's estimate and one dense Gauss-Newton step from
// its linearisation point over all its active factors: zero when R, d hold exactly those
// factors linearised at θ.
double differenceFromDenseStep(const IncrementalSolver& inc) {
  const PoseGraph& g = inc.graph();
  Eigen::VectorXd rhs;
  const Eigen::MatrixXd Hd = testing::denseHessian(g, &rhs);
  Values expected = g.values();
  expected.retractAll(Hd.ldlt().solve(rhs));
  const Values got = inc.estimate();
  double worst = 0.0;
  for (int v = 0; v < got.size(); ++v) {
    worst =
        std::max(worst, (expected.at(v).se3.inverse() * got.at(v).se3).log().cwiseAbs().maxCoeff());
  }
  return worst;
}

IncrementalOptions backgroundOptions(int lag) {
  IncrementalOptions o;
  o.batch_every = 8;
  o.background_batch_lag = lag;
  return o;
}

TEST(IncrementalSolverBackground,
     SwapsTheBatchInAtTheScheduledUpdateWithEveryFactorSinceRelinearised) {
  const Scenario s = spatialScenario(40, 0.02, 3);
  IncrementalSolver inc(backgroundOptions(3));
  int started = 0, swapped = 0;
  for (int i = 0; i < 40; ++i) {
    auto r = inc.update(poseRequest(s, inc, i));
    ASSERT_TRUE(r.ok()) << r.error().message;
    // Update k (1-based) is scheduled when (k - 1) % 8 == 0; the first one is synchronous.
    const int k = i + 1;
    EXPECT_EQ(r->batch, k == 1) << "update " << k;
    EXPECT_EQ(r->batch_started, k > 1 && (k - 1) % 8 == 0) << "update " << k;
    EXPECT_EQ(r->batch_swapped, k > 4 && (k - 4) % 8 == 0) << "update " << k;
    started += r->batch_started;
    swapped += r->batch_swapped;
    if (r->batch_swapped) {
      // R now holds the snapshot's factors at its estimate plus the later ones at θ.
      EXPECT_LT(differenceFromDenseStep(inc), 1e-8) << "update " << k;
      EXPECT_GE(r->batch_compute_s, 0.0);
    }
  }
  EXPECT_EQ(started, 4);
  EXPECT_EQ(swapped, 4);
}

TEST(IncrementalSolverBackground, GivesTheSameEstimatesWhateverTheWorkerSpeed) {
  // The swap point is an update count: two runs agree to the last bit, and a run whose worker
  // is always done before the swap (it waits right after each start) agrees with them too.
  const Scenario s = spatialScenario(40, 0.02, 5);
  std::vector<Values> runs;
  for (int run = 0; run < 3; ++run) {
    IncrementalSolver inc(backgroundOptions(2));
    for (int i = 0; i < 40; ++i) {
      auto r = inc.update(poseRequest(s, inc, i));
      ASSERT_TRUE(r.ok());
      if (run == 2 && r->batch_started) std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    runs.push_back(inc.estimate());
  }
  for (int run = 1; run < 3; ++run) {
    for (int v = 0; v < runs[0].size(); ++v) {
      EXPECT_EQ(runs[run].at(v).se3.translation(), runs[0].at(v).se3.translation())
          << "run " << run;
    }
  }
}

TEST(IncrementalSolverBackground, ReachesTheSameOptimumAsSynchronousBatchSteps) {
  const Scenario s = spatialScenario(60, 0.03, 7);
  double sse[2] = {0.0, 0.0};
  for (int lag : {0, 3}) {
    IncrementalSolver inc(backgroundOptions(lag));
    ASSERT_NO_FATAL_FAILURE(addPoses(inc, s, 60));
    for (int k = 0; k < 3; ++k) ASSERT_TRUE(inc.batchStep().ok());
    sse[lag > 0] = inc.cost().weighted_sse;
  }
  EXPECT_NEAR(sse[1], sse[0], 1e-6 * sse[0]);
}

TEST(IncrementalSolverBackground, AReplacementFactorStandsInForTheRemovedOneAfterTheSwap) {
  // At a scheduled update the caller replaces the factor of a pair by another over the same
  // variables (the mapper's consolidation of merged constraints): after the swap, R holds the
  // replacement and not the removed factor.
  const Scenario s = spatialScenario(30, 0.02, 9);
  IncrementalSolver inc(backgroundOptions(3));
  std::vector<FactorId> ids;
  for (int i = 0; i < 16; ++i) {
    auto r = inc.update(poseRequest(s, inc, i));
    ASSERT_TRUE(r.ok());
    ids.insert(ids.end(), r->new_factor_ids.begin(), r->new_factor_ids.end());
  }
  // Update 17 is scheduled: remove the 3 → 4 odometry factor, add a different one.
  UpdateRequest replace = poseRequest(s, inc, 16);
  const FactorId odometry_3_4 = ids[1 + 3 + 0];  // anchor, 0→1, 1→2, 2→3, then 3→4
  ASSERT_EQ(inc.graph().variablesOf(odometry_3_4)[0], 3);
  ASSERT_EQ(inc.graph().variablesOf(odometry_3_4)[1], 4);
  replace.remove_factors.push_back(odometry_3_4);
  replace.new_factors.push_back(
      edgeFactor(3, 4,
                 PoseValue::spatial(std::get<2>(s.edges[3]).se3 *
                                    SE3d::exp(Eigen::Matrix<double, 6, 1>::Constant(0.01)))));
  auto r = inc.update(replace);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_TRUE(r->batch_started);
  EXPECT_FALSE(r->batch);
  bool swapped = false;
  for (int i = 17; i < 21; ++i) {
    auto u = inc.update(poseRequest(s, inc, i));
    ASSERT_TRUE(u.ok());
    if (u->batch_swapped) {
      swapped = true;
      EXPECT_LT(differenceFromDenseStep(inc), 1e-8);
    }
  }
  EXPECT_TRUE(swapped);
}

TEST(IncrementalSolverBackground, RejectsOptionsItCannotHonour) {
  IncrementalOptions o = backgroundOptions(3);
  EXPECT_TRUE(o.validate().ok());
  o.method = Method::kDogLeg;
  EXPECT_FALSE(o.validate().ok());
  o = backgroundOptions(8);
  EXPECT_FALSE(o.validate().ok()) << "the lag must end before the next scheduled batch";
  o = backgroundOptions(-1);
  EXPECT_FALSE(o.validate().ok());
}

TEST(Marginals, JointOfTheSolverEqualsTheJointOfACopyOfItsFactor) {
  // After incremental updates (no batch step since): the path solves on the live factor.
  const Scenario s = spatialScenario(30, 0.02, 11);
  IncrementalSolver inc(withoutBatchSteps());
  ASSERT_NO_FATAL_FAILURE(addPoses(inc, s, 30));
  const std::vector<Key> keys = {4, 27};
  auto live = Marginals::jointOf(inc, keys);
  auto copied = Marginals::fromSolver(inc).joint(keys);
  ASSERT_TRUE(live.ok());
  ASSERT_TRUE(copied.ok());
  EXPECT_TRUE(live->isApprox(*copied, 1e-12));
  EXPECT_GT(live->diagonal().minCoeff(), 0.0);
  const std::vector<Key> unknown = {4, 99};
  EXPECT_FALSE(Marginals::jointOf(inc, unknown).ok());
}

}  // namespace
}  // namespace evermap::solver
