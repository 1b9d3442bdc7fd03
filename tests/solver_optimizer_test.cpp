// core/solver: square-root factor against dense QR, batch and incremental optimisation on
// small graphs with known answers, factor removal, marginals against a dense inverse.
#include <gtest/gtest.h>

#include <random>

#include <Eigen/Dense>

#include "core/solver/batch_solver.h"
#include "core/solver/gnc.h"
#include "core/solver/graph_io.h"
#include "core/solver/graph_problem.h"
#include "core/solver/incremental_solver.h"
#include "core/solver/marginals.h"
#include "core/solver/normal_equations.h"
#include "core/solver/pose_factors.h"
#include "core/solver/square_root_factor.h"
#include "solver_scenarios.h"

namespace evermap::solver {
namespace {

using testing::edgeFactor;
using testing::planarScenario;
using testing::poseRequest;
using testing::Scenario;
using testing::spatialScenario;

using core::SE2d;
using core::SE3d;

FactorPtr anchor(const PoseValue& p) {
  if (p.kind == PoseKind::kSE2) return makeAnchorFactor(0, 2);
  return makeAnchorFactor(0, 3);
}

// Odometry-chained initial values (the measurements composed along the path).
PoseGraph buildGraph(const Scenario& s) {
  PoseGraph g;
  PoseValue x = s.truth[0];
  EXPECT_TRUE(g.addVariable(0, x).ok());
  for (const auto& [a, b, z] : s.edges) {
    if (b == a + 1) {
      x = x.kind == PoseKind::kSE2 ? PoseValue::planar(x.se2 * z.se2)
                                   : PoseValue::spatial(x.se3 * z.se3);
      EXPECT_TRUE(g.addVariable(b, x).ok());
    }
  }
  EXPECT_TRUE(g.addFactor(anchor(s.truth[0])).ok());
  for (const auto& [a, b, z] : s.edges) EXPECT_TRUE(g.addFactor(edgeFactor(a, b, z)).ok());
  return g;
}

double maxPoseError(const Values& v, const std::vector<PoseValue>& truth) {
  double e = 0.0;
  for (int i = 0; i < v.size(); ++i) {
    const PoseValue& t = truth[v.keyAt(i)];
    if (t.kind == PoseKind::kSE2) {
      e = std::max(e, (v.at(i).se2.vector() - t.se2.vector()).cwiseAbs().maxCoeff());
    } else {
      e = std::max(e, (t.se3.inverse() * v.at(i).se3).log().cwiseAbs().maxCoeff());
    }
  }
  return e;
}

TEST(SquareRootFactor, HouseholderUpdatesReproduceTheNormalEquations) {
  // Random block rows eliminated one by one: RᵀR = AᵀA and Rᵀd = Aᵀb.
  std::mt19937 rng(3);
  std::normal_distribution<double> nd(0.0, 1.0);
  const int n = 6;
  SquareRootFactor R;
  for (int p = 0; p < n; ++p) R.appendPosition(3);
  Eigen::MatrixXd Adense = Eigen::MatrixXd::Zero(0, 3 * n);
  Eigen::VectorXd bdense(0);
  for (int k = 0; k < 12; ++k) {
    const int a = k < n ? k : static_cast<int>(rng() % n);
    int b = k < n ? (k + 1) % n : static_cast<int>(rng() % n);
    if (b == a) b = (a + 2) % n;
    std::vector<int> pos = {std::min(a, b), std::max(a, b)};
    Eigen::MatrixXd A(3, 6);
    Eigen::VectorXd rhs(3);
    for (int i = 0; i < A.size(); ++i) A.data()[i] = nd(rng);
    for (int i = 0; i < 3; ++i) rhs[i] = nd(rng);
    R.addRows(pos, A, rhs);
    Eigen::MatrixXd row = Eigen::MatrixXd::Zero(3, 3 * n);
    row.middleCols(3 * pos[0], 3) = A.leftCols(3);
    row.middleCols(3 * pos[1], 3) = A.rightCols(3);
    Adense.conservativeResize(Adense.rows() + 3, Eigen::NoChange);
    Adense.bottomRows(3) = row;
    bdense.conservativeResize(bdense.size() + 3);
    bdense.tail(3) = rhs;
  }
  Eigen::MatrixXd Rd = Eigen::MatrixXd::Zero(3 * n, 3 * n);
  for (int p = 0; p < n; ++p) {
    const auto& r = R.row(p);
    for (size_t c = 0; c < r.cols.size(); ++c) {
      Rd.block(3 * p, 3 * r.cols[c], 3, 3) = r.A.middleCols(r.offsets[c], 3);
    }
  }
  const Eigen::MatrixXd H = Adense.transpose() * Adense;
  EXPECT_LT((Rd.transpose() * Rd - H).cwiseAbs().maxCoeff(), 1e-10);
  EXPECT_LT((Rd.transpose() * R.rhs() - Adense.transpose() * bdense).cwiseAbs().maxCoeff(), 1e-10);
  Eigen::VectorXd x;
  ASSERT_TRUE(R.backSubstitute(&x).ok());
  const Eigen::VectorXd expected = H.ldlt().solve(Adense.transpose() * bdense);
  EXPECT_LT((x - expected).cwiseAbs().maxCoeff(), 1e-9);
  // Partial back substitution with threshold 0 from a stale solution gives the same answer.
  Eigen::VectorXd y = x;
  y.head(3).setConstant(5.0);
  std::vector<char> dirty(n, 0);
  dirty[0] = 1;
  ASSERT_TRUE(R.backSubstitutePartial(dirty, 0.0, &y).ok());
  EXPECT_LT((y - x).cwiseAbs().maxCoeff(), 1e-12);
  // Rᵀ solve.
  const Eigen::VectorXd g = Eigen::VectorXd::LinSpaced(3 * n, -1.0, 1.0);
  EXPECT_LT((Rd.transpose() * R.solveTranspose(g) - g).cwiseAbs().maxCoeff(), 1e-10);
}

TEST(SquareRootFactor, ReportsAVariableWithoutFactorsInsteadOfDividingByZero) {
  SquareRootFactor R;
  R.appendPosition(3);
  R.appendPosition(3);
  R.addRows(std::vector<int>{0}, Eigen::MatrixXd::Identity(3, 3), Eigen::VectorXd::Ones(3));
  Eigen::VectorXd x;
  const Status st = R.backSubstitute(&x);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().message.find("no factor"), std::string::npos);
}

TEST(BatchSolver, RecoversNoiseFreePosesFromOdometryDriftForEveryMethod) {
  for (Method m : {Method::kGaussNewton, Method::kLevenbergMarquardt, Method::kDogLeg}) {
    for (bool spatial : {false, true}) {
      Scenario s = spatial ? spatialScenario(30, 0.0, 1) : planarScenario(40, 0.0, 1);
      PoseGraph g = buildGraph(s);
      // Perturb the initial values so that the solver has work to do.
      Values& v = g.mutableValues();
      for (int i = 1; i < v.size(); ++i) {
        double d[6] = {0.2, -0.1, 0.05, 0.02, -0.03, 0.04};
        v.at(i) = retract(v.at(i), d);
      }
      BatchOptions o;
      o.method = m;
      const BatchSummary sum = solveBatch(g, o);
      ASSERT_TRUE(sum.ok()) << sum.message;
      EXPECT_LT(sum.final_cost, 1e-12) << methodName(m);
      EXPECT_LT(maxPoseError(g.values(), s.truth), 1e-6) << methodName(m) << " spatial " << spatial;
    }
  }
}

TEST(BatchSolver, AllMethodsReachTheSameMinimumOnANoisyGraph) {
  std::vector<double> costs;
  for (Method m : {Method::kGaussNewton, Method::kLevenbergMarquardt, Method::kDogLeg}) {
    PoseGraph g = buildGraph(spatialScenario(40, 0.05, 2));
    BatchOptions o;
    o.method = m;
    o.relative_cost_tolerance = 1e-14;
    const BatchSummary sum = solveBatch(g, o);
    ASSERT_TRUE(sum.ok()) << sum.message;
    costs.push_back(sum.final_cost);
  }
  EXPECT_GT(costs[0], 1.0);
  EXPECT_NEAR(costs[1], costs[0], 1e-6 * costs[0]);
  EXPECT_NEAR(costs[2], costs[0], 1e-6 * costs[0]);
}

TEST(BatchSolver, ReportsNotConvergedWhenTheIterationBudgetRunsOut) {
  for (Method m : {Method::kGaussNewton, Method::kLevenbergMarquardt, Method::kDogLeg}) {
    PoseGraph g = buildGraph(spatialScenario(40, 0.05, 2));
    BatchOptions o;
    o.method = m;
    o.max_iterations = 1;
    const BatchSummary one = solveBatch(g, o);
    EXPECT_TRUE(one.ok()) << one.message;
    EXPECT_EQ(one.termination, Termination::kMaxIterations) << methodName(m);
    EXPECT_FALSE(one.converged());
    EXPECT_NE(one.message.find("NOT converged"), std::string::npos) << one.message;
    // The default budget lets the same problem converge from where it stopped.
    const BatchSummary rest = solveBatch(g, BatchOptions{.method = m});
    EXPECT_TRUE(rest.converged()) << rest.message;
    EXPECT_LT(rest.final_cost, one.final_cost);
  }
}

TEST(BatchSolver, StartedAtAMinimumStopsOnTheGradientWithoutIterating) {
  // Noise-free measurements at the true poses: the gradient is zero to rounding.
  Scenario s = planarScenario(40, 0.0, 1);
  PoseGraph g = buildGraph(s);
  for (int i = 0; i < g.values().size(); ++i)
    g.mutableValues().at(i) = s.truth[g.values().keyAt(i)];
  BatchOptions o;
  o.gradient_tolerance = 1e-9;
  const BatchSummary sum = solveBatch(g, o);
  EXPECT_EQ(sum.termination, Termination::kSmallGradient) << sum.message;
  EXPECT_EQ(sum.iterations, 0);
  EXPECT_LE(sum.final_gradient_max, 1e-9);
  // A perturbed start is not at a minimum: the gradient test must not fire before a step.
  double d[3] = {0.1, 0.0, 0.02};
  g.mutableValues().at(5) = retract(g.values().at(5), d);
  const BatchSummary moved = solveBatch(g, o);
  EXPECT_GT(moved.iterations, 0);
  EXPECT_TRUE(moved.converged()) << moved.message;
}

TEST(Gnc, RejectsGrossFalseLoopClosuresThatLeastSquaresAbsorbs) {
  Scenario s = planarScenario(60, 0.01, 4);
  std::mt19937 rng(9);
  std::uniform_int_distribution<int> pose(0, 59);
  std::vector<std::tuple<int, int, PoseValue>> wrong;
  while (wrong.size() < 6) {
    const int a = pose(rng);
    const int b = pose(rng);
    if (std::abs(a - b) < 2) continue;
    wrong.emplace_back(std::min(a, b), std::max(a, b), PoseValue::planar(SE2d(3.0, -2.0, 1.0)));
  }
  auto solve = [&](bool with_outliers, const RobustKernel& k) {
    PoseGraph g = buildGraph(s);
    if (with_outliers) {
      for (const auto& [a, b, z] : wrong) {
        FactorPtr f = edgeFactor(a, b, z);
        f->setKernel(kernelForFactor(k, f->dim()));
        EXPECT_TRUE(g.addFactor(f).ok());
      }
    }
    // Every loop closure is a candidate, true ones included.
    for (FactorId id = 1; id < g.numFactorSlots(); ++id) {
      if (g.variablesOf(id).size() == 2 &&
          std::abs(g.variablesOf(id)[0] - g.variablesOf(id)[1]) > 1) {
        g.factorPtr(id)->setKernel(kernelForFactor(k, 3));
      }
    }
    GncOptions o;
    o.final_stage.verbose = std::getenv("EVERMAP_GNC_VERBOSE") != nullptr;
    const GncSummary sum = solveGnc(g, o);
    EXPECT_TRUE(sum.batch.converged()) << sum.batch.message;
    return std::make_pair(maxPoseError(g.values(), s.truth), sum);
  };
  const RobustKernel gnc = *parseRobustKernel("gnc");
  const auto [clean_error, clean] = solve(false, gnc);
  const auto [error, sum] = solve(true, gnc);
  EXPECT_EQ(sum.rejected, 6) << "of " << sum.candidates;
  EXPECT_GT(sum.stages, 1);
  EXPECT_NEAR(error, clean_error, 1e-6);
  // Plain least squares is pulled away by the same closures.
  PoseGraph plain = buildGraph(s);
  for (const auto& [a, b, z] : wrong) ASSERT_TRUE(plain.addFactor(edgeFactor(a, b, z)).ok());
  ASSERT_TRUE(solveBatch(plain, BatchOptions{}).ok());
  EXPECT_GT(maxPoseError(plain.values(), s.truth), 10.0 * clean_error);
}

TEST(BatchSolver, FailsWithAMessageWhenTheGaugeIsFree) {
  PoseGraph g;
  ASSERT_TRUE(g.addVariable(0, PoseValue::planar(SE2d())).ok());
  ASSERT_TRUE(g.addVariable(1, PoseValue::planar(SE2d(1, 0, 0))).ok());
  ASSERT_TRUE(g.addFactor(edgeFactor(0, 1, PoseValue::planar(SE2d(1, 0, 0)))).ok());
  const BatchSummary s = solveBatch(g, BatchOptions{});
  EXPECT_FALSE(s.ok());
  EXPECT_NE(s.message.find("positive definite"), std::string::npos);
}

TEST(PoseGraph, RejectsUnknownKeysWrongKindsAndDoubleRemoval) {
  PoseGraph g;
  ASSERT_TRUE(g.addVariable(0, PoseValue::planar(SE2d())).ok());
  EXPECT_FALSE(g.addVariable(0, PoseValue::planar(SE2d())).ok());
  EXPECT_FALSE(g.addFactor(edgeFactor(0, 5, PoseValue::planar(SE2d()))).ok());
  ASSERT_TRUE(g.addVariable(1, PoseValue::spatial(SE3d())).ok());
  EXPECT_FALSE(g.addFactor(edgeFactor(0, 1, PoseValue::planar(SE2d()))).ok());
  auto id = g.addFactor(makeAnchorFactor(0, 2));
  ASSERT_TRUE(id.ok());
  EXPECT_TRUE(g.removeFactor(*id).ok());
  EXPECT_FALSE(g.removeFactor(*id).ok());
}

TEST(IncrementalSolver, MatchesBatchWhenFedStepByStep) {
  for (Method m : {Method::kGaussNewton, Method::kDogLeg}) {
    const Scenario s = planarScenario(60, 0.03, 5);
    IncrementalOptions io;
    io.method = m;
    io.batch_every = 25;
    IncrementalSolver inc(io);
    for (int i = 0; i < static_cast<int>(s.truth.size()); ++i) {
      auto res = inc.update(poseRequest(s, inc, i));
      ASSERT_TRUE(res.ok()) << res.error().message;
    }
    ASSERT_TRUE(inc.batchStep().ok());
    ASSERT_TRUE(inc.batchStep().ok());
    PoseGraph batch = buildGraph(s);
    BatchOptions bo;
    bo.relative_cost_tolerance = 1e-14;
    ASSERT_TRUE(solveBatch(batch, bo).ok());
    EXPECT_NEAR(inc.cost().weighted_sse, batch.cost().weighted_sse,
                1e-6 * batch.cost().weighted_sse)
        << methodName(m);
  }
}

TEST(IncrementalSolver, IncrementalStepsKeepRConsistentWithABatchFactorisation) {
  // Without batch steps R is only updated by Householder reflections; its normal equations
  // must still equal AᵀA of all factors linearised at θ: check via the solution.
  const Scenario s = spatialScenario(20, 0.02, 9);
  IncrementalSolver inc(testing::withoutBatchSteps());
  ASSERT_NO_FATAL_FAILURE(testing::addPoses(inc, s, 20));
  // One Gauss-Newton step from θ computed densely.
  const PoseGraph& g = inc.graph();
  Eigen::VectorXd rhs;
  const Eigen::VectorXd step = testing::denseHessian(g, &rhs).ldlt().solve(rhs);
  Values expected = g.values();
  expected.retractAll(step);
  EXPECT_LT(maxPoseError(inc.estimate(),
                         [&] {
                           std::vector<PoseValue> t;
                           for (int i = 0; i < expected.size(); ++i) t.push_back(expected.at(i));
                           return t;
                         }()),
            1e-8);
}

TEST(IncrementalSolver, RemovingAFalseLoopClosureRestoresTheCleanSolution) {
  const Scenario s = planarScenario(30, 0.01, 4);
  IncrementalSolver inc;
  UpdateRequest all;
  PoseGraph clean = buildGraph(s);
  for (int i = 0; i < clean.values().size(); ++i) {
    all.new_variables.emplace_back(clean.values().keyAt(i), clean.values().at(i));
  }
  all.new_factors.push_back(anchor(s.truth[0]));
  for (const auto& [a, b, z] : s.edges) all.new_factors.push_back(edgeFactor(a, b, z));
  all.new_factors.push_back(edgeFactor(3, 20, PoseValue::planar(SE2d(5.0, -3.0, 2.0))));
  auto r = inc.update(all);
  ASSERT_TRUE(r.ok());
  const FactorId outlier = r->new_factor_ids.back();
  BatchOptions bo;
  bo.relative_cost_tolerance = 1e-14;
  inc.optimize(bo);
  UpdateRequest removal;
  removal.remove_factors.push_back(outlier);
  auto r2 = inc.update(removal);
  ASSERT_TRUE(r2.ok());
  EXPECT_TRUE(r2->batch);
  EXPECT_FALSE(inc.update(removal).ok()) << "removing twice is an error";
  inc.optimize(bo);
  ASSERT_TRUE(solveBatch(clean, bo).ok());
  EXPECT_NEAR(inc.cost().weighted_sse, clean.cost().weighted_sse, 1e-8 * clean.cost().weighted_sse);
}

TEST(IncrementalSolver, RejectsInvalidRequestsWithoutChangingState) {
  IncrementalSolver inc;
  UpdateRequest r;
  r.new_variables.emplace_back(0, PoseValue::planar(SE2d()));
  r.new_factors.push_back(edgeFactor(0, 1, PoseValue::planar(SE2d())));
  EXPECT_FALSE(inc.update(r).ok());
  EXPECT_EQ(inc.graph().values().size(), 0);
  IncrementalOptions lm;
  lm.method = Method::kLevenbergMarquardt;
  EXPECT_FALSE(lm.validate().ok());
}

GraphFile asFile(const Scenario& s) {
  GraphFile g;
  g.dimension = s.truth[0].kind == PoseKind::kSE2 ? 2 : 3;
  g.format = GraphFormat::kG2o;
  int line = 1;
  for (const auto& [a, b, z] : s.edges) {
    GraphEdge e;
    e.from = a;
    e.to = b;
    e.measurement = z;
    e.sqrt_information =
        Eigen::MatrixXd::Identity(g.dimension == 2 ? 3 : 6, g.dimension == 2 ? 3 : 6);
    e.line = line++;
    g.edges.push_back(e);
  }
  return g;
}

TEST(Initialization, ChordalRelaxationIsExactOnNoiseFreeGraphs) {
  for (bool spatial : {false, true}) {
    const Scenario s = spatial ? spatialScenario(25, 0.0, 6) : planarScenario(40, 0.0, 6);
    auto v = chordalInitialization(asFile(s));
    ASSERT_TRUE(v.ok()) << v.error().message;
    EXPECT_EQ(v->size(), static_cast<int>(s.truth.size()));
    EXPECT_LT(maxPoseError(*v, s.truth), 1e-9) << "spatial " << spatial;
    auto odo = odometryInitialization(asFile(s));
    ASSERT_TRUE(odo.ok());
    EXPECT_LT(maxPoseError(*odo, s.truth), 1e-9);
  }
}

TEST(Initialization, ChordalBeatsOdometryChainingOnNoisyGraphs) {
  const Scenario s = spatialScenario(60, 0.05, 7);
  const GraphFile g = asFile(s);
  auto chordal = chordalInitialization(g);
  auto odo = odometryInitialization(g);
  ASSERT_TRUE(chordal.ok());
  ASSERT_TRUE(odo.ok());
  EXPECT_LT(seSyncCost(g, *chordal), seSyncCost(g, *odo));
}

TEST(Initialization, ReportsPosesThatNoEdgeConnects) {
  Scenario s = planarScenario(10, 0.0, 1);
  s.edges.emplace_back(20, 21, PoseValue::planar(SE2d(1, 0, 0)));
  auto v = odometryInitialization(asFile(s));
  ASSERT_FALSE(v.ok());
  EXPECT_NE(v.error().message.find("not connected"), std::string::npos);
}

TEST(PartialPriors, RollPitchAndHeightFixOnlyWhatTheyMeasure) {
  // One pose with a roll/pitch prior and a height prior, from a start with every
  // coordinate wrong: the solve moves roll, pitch and z to the priors and leaves x, y and
  // yaw where they were (the normal equations are singular in them, so use LM's damping).
  PoseGraph g;
  const SE3d start(core::SO3d::fromRollPitchYaw(0.3, -0.2, 1.0), core::Vec3(4.0, -2.0, 7.0));
  ASSERT_TRUE(g.addVariable(0, PoseValue::spatial(start)).ok());
  ASSERT_TRUE(g.addFactor(std::make_shared<RollPitchFactor>(
                              0, 0.05, 0.02, 100.0 * Eigen::MatrixXd::Identity(2, 2)))
                  .ok());
  ASSERT_TRUE(g.addFactor(std::make_shared<HeightFactor>(0, 1.5, 0.01)).ok());
  BatchOptions o;
  o.method = Method::kLevenbergMarquardt;
  o.lm_initial_lambda = 1e-3;
  ASSERT_TRUE(solveBatch(g, o).ok());
  const SE3d& p = g.values().at(0).se3;
  const core::Vec3 ypr = yawPitchRoll(p.rotationMatrix());
  EXPECT_NEAR(ypr[2], 0.05, 1e-6);
  EXPECT_NEAR(ypr[1], 0.02, 1e-6);
  EXPECT_NEAR(p.translation().z(), 1.5, 1e-6);
  EXPECT_NEAR(ypr[0], 1.0, 0.05) << "yaw is not observed";
  EXPECT_NEAR(p.translation().x(), 4.0, 0.5) << "x is not observed";
}

TEST(Marginals, EqualTheBlocksOfTheDenseInverse) {
  for (bool spatial : {false, true}) {
    PoseGraph g = buildGraph(spatial ? spatialScenario(15, 0.02, 3) : planarScenario(25, 0.02, 3));
    ASSERT_TRUE(solveBatch(g, BatchOptions{}).ok());
    const BlockPattern pat = buildPattern(g);
    Eigen::VectorXd rhs;
    const Eigen::MatrixXd cov = testing::denseHessian(g, &rhs).inverse();
    auto m = Marginals::compute(g);
    ASSERT_TRUE(m.ok());
    const std::vector<Key> keys = {3, 11, 7};
    auto joint = m->joint(keys);
    ASSERT_TRUE(joint.ok());
    const int d = spatial ? 6 : 3;
    for (size_t a = 0; a < keys.size(); ++a) {
      for (size_t b = 0; b < keys.size(); ++b) {
        const Eigen::MatrixXd expected = cov.block(pat.offset(g.values().indexOf(keys[a])),
                                                   pat.offset(g.values().indexOf(keys[b])), d, d);
        const Eigen::MatrixXd got = joint->block(d * a, d * b, d, d);
        EXPECT_LT((got - expected).cwiseAbs().maxCoeff(),
                  1e-9 * (1.0 + expected.cwiseAbs().maxCoeff()));
      }
    }
    auto single = m->marginal(11);
    ASSERT_TRUE(single.ok());
    EXPECT_TRUE(single->isApprox(joint->block(d, d, d, d), 1e-12));
    EXPECT_FALSE(m->marginal(999).ok());
  }
}

TEST(Marginals, FromTheIncrementalSolverMatchBatchAtTheSamePoint) {
  PoseGraph g = buildGraph(planarScenario(20, 0.02, 8));
  ASSERT_TRUE(solveBatch(g, BatchOptions{}).ok());
  IncrementalSolver inc;
  UpdateRequest all;
  for (int i = 0; i < g.values().size(); ++i)
    all.new_variables.emplace_back(g.values().keyAt(i), g.values().at(i));
  for (FactorId id = 0; id < g.numFactorSlots(); ++id) all.new_factors.push_back(g.factorPtr(id));
  ASSERT_TRUE(inc.update(all).ok());  // first update is a batch step at these values
  auto a = Marginals::fromSolver(inc).marginal(12);
  auto b = Marginals::compute(g)->marginal(12);
  ASSERT_TRUE(a.ok());
  ASSERT_TRUE(b.ok());
  EXPECT_TRUE(a->isApprox(*b, 1e-9));
}

}  // namespace
}  // namespace evermap::solver
