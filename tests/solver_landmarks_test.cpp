// Point landmarks in core/solver: the pose→point factors' Jacobians against central
// differences, iSAM's and g2o's landmark lines read (and refused when malformed, naming
// file:line), and generated cityTrees-like (2-D) and torusPoints-like (3-D) problems solved
// to their known truth, batch and incremental alike.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>

#include "core/solver/batch_solver.h"
#include "core/solver/graph_io.h"
#include "core/solver/graph_problem.h"
#include "core/solver/landmark_factors.h"
#include "core/solver/online_runner.h"
#include "core/solver/outliers.h"
#include "tools/sim/landmark_graphs.h"

#include "tests/solver_test_util.h"

namespace evermap::solver {
namespace {

using testing::jacobianError;
using testing::readGraphText;
using testing::TempFile;

namespace fs = std::filesystem;
using core::SE2d;
using core::SE3d;
using core::Vec2;
using core::Vec3;

std::mt19937 rng(7);

Vec3 randomVec3(double scale) {
  std::normal_distribution<double> n(0.0, scale);
  return Vec3(n(rng), n(rng), n(rng));
}

SE3d randomSE3() {
  std::normal_distribution<double> n(0.0, 1.0);
  return SE3d(core::SO3d::exp(Vec3(n(rng), n(rng), n(rng))), randomVec3(3.0));
}

Eigen::MatrixXd upperSqrt(int n) {
  Eigen::MatrixXd W = Eigen::MatrixXd::Identity(n, n) * 3.0;
  W(0, 1) = 0.5;
  return W;
}

TEST(SolverLandmarks, PosePoint2JacobiansMatchNumericalDerivatives) {
  std::uniform_real_distribution<double> u(-3.0, 3.0);
  for (int trial = 0; trial < 20; ++trial) {
    const PosePoint2Factor f(0, 1, Vec2(u(rng), u(rng)), upperSqrt(2));
    const std::vector<PoseValue> x = {PoseValue::planar(SE2d(u(rng), u(rng), u(rng))),
                                      PoseValue::point2(Vec2(u(rng), u(rng)))};
    EXPECT_LT(jacobianError(f, x), 1e-7) << "trial " << trial;
  }
}

TEST(SolverLandmarks, PosePoint3JacobiansMatchNumericalDerivativesWithAndWithoutSensorOffset) {
  for (int trial = 0; trial < 20; ++trial) {
    const SE3d offset = trial % 2 == 0 ? SE3d() : randomSE3();
    const PosePoint3Factor f(0, 1, randomVec3(2.0), upperSqrt(3), offset);
    const std::vector<PoseValue> x = {PoseValue::spatial(randomSE3()),
                                      PoseValue::point3(randomVec3(4.0))};
    EXPECT_LT(jacobianError(f, x), 1e-7) << "trial " << trial;
  }
}

TEST(SolverLandmarks, TheInitialValueOfANewLandmarkReproducesItsMeasurement) {
  const PoseValue a2 = PoseValue::planar(SE2d(1.0, -2.0, 0.7));
  const Vec3 z2(2.0, 0.5, 0.0);
  const PoseValue l2 = observationInitialValue(a2, z2);
  ASSERT_EQ(l2.kind, PoseKind::kPoint2);
  const PosePoint2Factor f2(0, 1, z2.head<2>(), upperSqrt(2));
  std::vector<const PoseValue*> x2 = {&a2, &l2};
  Vec2 r2;
  f2.evaluate(x2, r2.data(), nullptr);
  EXPECT_LT(r2.norm(), 1e-12);

  const PoseValue a3 = PoseValue::spatial(randomSE3());
  const SE3d offset = randomSE3();
  const Vec3 z3(1.0, -0.5, 3.0);
  const PoseValue l3 = observationInitialValue(a3, z3, offset);
  ASSERT_EQ(l3.kind, PoseKind::kPoint3);
  const PosePoint3Factor f3(0, 1, z3, upperSqrt(3), offset);
  std::vector<const PoseValue*> x3 = {&a3, &l3};
  Vec3 r3;
  f3.evaluate(x3, r3.data(), nullptr);
  EXPECT_LT(r3.norm(), 1e-12);
}

TEST(SolverLandmarks, ReadsIsamLandmarkAndPoint3LinesWithTheirSquareRootInformation) {
  auto g = readGraphText("a.txt",
                         "ODOMETRY 0 1 1 0 0 10 0 0 10 0 20\n"
                         "LANDMARK 1 0 2.5 -1 5 0.5 4\n"
                         "LANDMARK 0 0 3.5 -1 5 0 5\n");
  ASSERT_TRUE(g.ok()) << g.error().message;
  EXPECT_EQ(g->format, GraphFormat::kIsam);
  EXPECT_EQ(g->skippedLines(), 0);
  ASSERT_EQ(g->observations.size(), 2u);
  EXPECT_EQ(g->numLandmarks(), 1);
  const GraphObservation& o = g->observations[0];
  EXPECT_EQ(o.pose, 1);
  EXPECT_EQ(o.landmark, isamLandmarkKey(0));
  EXPECT_EQ(o.line, 2);
  EXPECT_EQ(o.edges_before, 1);
  EXPECT_DOUBLE_EQ(o.measured.x(), 2.5);
  EXPECT_DOUBLE_EQ(o.sqrt_information(0, 1), 0.5);
  EXPECT_DOUBLE_EQ(o.sqrt_information(1, 0), 0.0);
  EXPECT_DOUBLE_EQ(o.sqrt_information(1, 1), 4.0);

  auto h = readGraphText("b.txt",
                         "EDGE3 0 1 1 0 0 0 0 0\n"
                         "POINT3 1 4 1 2 3\n"
                         "POINT3 0 4 2 2 3 10 1 2 10 3 10\n");
  ASSERT_TRUE(h.ok()) << h.error().message;
  EXPECT_EQ(h->dimension, 3);
  ASSERT_EQ(h->observations.size(), 2u);
  EXPECT_TRUE(h->observations[0].sqrt_information.isIdentity());  // no numbers: identity (iSAM)
  EXPECT_DOUBLE_EQ(h->observations[1].sqrt_information(1, 2), 3.0);
  EXPECT_DOUBLE_EQ(h->observations[1].measured.z(), 3.0);
}

TEST(SolverLandmarks, ReadsG2oLandmarkVerticesEdgesAndSensorOffsets) {
  auto g = readGraphText("c.g2o",
                         "VERTEX_SE2 0 0 0 0\n"
                         "VERTEX_XY 5 1 2\n"
                         "EDGE_SE2_XY 0 5 1 2 100 10 400\n");
  ASSERT_TRUE(g.ok()) << g.error().message;
  ASSERT_EQ(g->landmarks.size(), 1u);
  ASSERT_EQ(g->observations.size(), 1u);
  EXPECT_EQ(g->observations[0].landmark, 5);
  const Eigen::MatrixXd& W = g->observations[0].sqrt_information;
  const Eigen::MatrixXd I = W.transpose() * W;
  EXPECT_NEAR(I(0, 1), 10.0, 1e-9);
  EXPECT_NEAR(I(1, 1), 400.0, 1e-9);
  auto init = fileInitialization(*g);
  ASSERT_TRUE(init.ok()) << init.error().message;
  EXPECT_EQ((*init)[5].kind, PoseKind::kPoint2);

  auto h = readGraphText("d.g2o",
                         "PARAMS_SE3OFFSET 3 0.1 0 0.2 0 0 0.7071068 0.7071068\n"
                         "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\n"
                         "VERTEX_TRACKXYZ 9 1 2 3\n"
                         "EDGE_SE3_TRACKXYZ 0 9 3 1 2 3 10 0 0 10 0 10\n");
  ASSERT_TRUE(h.ok()) << h.error().message;
  ASSERT_EQ(h->observations.size(), 1u);
  EXPECT_EQ(h->observations[0].offset_param, 3);
  EXPECT_NEAR(h->observations[0].pose_T_sensor.translation().z(), 0.2, 1e-12);
}

TEST(SolverLandmarks, AMalformedLandmarkLineIsOneErrorNamingFileAndLine) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"ODOMETRY 0 1 1 0 0 10 0 0 10 0 20\nLANDMARK 1 0 2.5 -1 5 0.5\n", ":2:"},     // short
      {"ODOMETRY 0 1 1 0 0 10 0 0 10 0 20\nLANDMARK 1 x 2.5 -1 5 0.5 4\n", ":2:"},   // id
      {"ODOMETRY 0 1 1 0 0 10 0 0 10 0 20\nLANDMARK 1 0 2.5 nan 5 0.5 4\n", ":2:"},  // NaN
      {"ODOMETRY 0 1 1 0 0 10 0 0 10 0 20\nLANDMARK 1 0 2.5 1 0 0.5 4\n", ":2:"},    // singular
      {"ODOMETRY 0 1 1 0 0 10 0 0 10 0 20\nPOINT3 1 0 1 2 3\n", ":2:"},              // 3-D in 2-D
      {"EDGE3 0 1 1 0 0 0 0 0\nPOINT3 1 0 1 2 3 1 0 0 1 0\n", ":2:"},                // 10 numbers
  };
  for (size_t k = 0; k < cases.size(); ++k) {
    TempFile f("bad" + std::to_string(k) + ".txt", cases[k].first);
    auto g = readGraphFile(f.path(), GraphFormat::kIsam);
    ASSERT_FALSE(g.ok()) << "case " << k;
    EXPECT_NE(g.error().message.find(f.path().string() + cases[k].second), std::string::npos)
        << g.error().message;
    EXPECT_EQ(g.error().message.find('\n'), std::string::npos) << "one line: " << g.error().message;
  }
  const std::vector<std::pair<std::string, std::string>> g2o = {
      {"VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\nEDGE_SE3_TRACKXYZ 0 9 3 1 2 3 10 0 0 10 0 10\n", ":2:"},
      {"VERTEX_SE2 0 0 0 0\nEDGE_SE2_XY 0 5 1 2 100 0 -4\n", ":2:"},  // not positive definite
      {"VERTEX_SE2 0 0 0 0\nVERTEX_XY 0 1 2\n", ":2:"},               // id of a pose
  };
  for (size_t k = 0; k < g2o.size(); ++k) {
    TempFile f("badg2o" + std::to_string(k) + ".g2o", g2o[k].first);
    auto g = readGraphFile(f.path());
    ASSERT_FALSE(g.ok()) << "case " << k;
    EXPECT_NE(g.error().message.find(f.path().string() + g2o[k].second), std::string::npos)
        << g.error().message;
  }
}

// ---------------------------------------------------------------- solved to the truth

struct Solved {
  double sse = 0.0;
  int64_t dof = 0;
  double pose_error = 0.0;      // max position error (m) against the truth
  double landmark_error = 0.0;  // RMS landmark position error (m)
  int iterations = 0;
  bool converged = false;
  // SSE (anchor included) at the truth minus at the estimate: to first order ‖J δ‖² with
  // δ the estimation error, a χ² sample with `unknowns` degrees of freedom.
  double truth_excess = 0.0;
  int unknowns = 0;
};

GraphFile readGenerated(const sim::LandmarkGraph& lg, const std::string& name) {
  auto g = readGraphText(name, lg.isam_text);
  EXPECT_TRUE(g.ok()) << g.error().message;
  return *g;
}

Solved compare(const sim::LandmarkGraph& lg, const PoseGraph& graph, const Values& x,
               const BatchSummary& s) {
  Solved out;
  out.iterations = s.iterations;
  out.converged = s.converged();
  for (FactorId id = 1; id < graph.numFactorSlots(); ++id) {  // factor 0: the anchor
    const Cost c = graph.cost(x, id);
    out.sse += c.weighted_sse;
    out.dof += c.residual_dim;
  }
  out.dof -= x.totalDim() - x.at(0).dim();
  for (int i = 0; i < x.size(); ++i) {
    const PoseValue& v = x.at(i);
    if (v.isPoint()) continue;
    const Vec3 t = v.kind == PoseKind::kSE2 ? Vec3(v.se2.x(), v.se2.y(), 0.0) : v.se3.translation();
    const Key k = x.keyAt(i);
    const Vec3 truth = lg.dimension == 2 ? Vec3(lg.poses2[k].x(), lg.poses2[k].y(), 0.0)
                                         : lg.poses3[k].translation();
    out.pose_error = std::max(out.pose_error, (t - truth).norm());
  }
  Values truth;
  for (int i = 0; i < x.size(); ++i) {
    const Key k = x.keyAt(i);
    if (x.at(i).isPoint()) {
      const Vec3& l = lg.points[k - kIsamLandmarkKeyBase];
      truth.add(k, lg.dimension == 2 ? PoseValue::point2(l.head<2>()) : PoseValue::point3(l));
    } else {
      truth.add(k, lg.dimension == 2 ? PoseValue::planar(lg.poses2[k])
                                     : PoseValue::spatial(lg.poses3[k]));
    }
  }
  out.truth_excess = graph.cost(truth).weighted_sse - graph.cost(x).weighted_sse;
  out.unknowns = x.totalDim();
  double sum = 0.0;
  for (size_t j = 0; j < lg.points.size(); ++j) {
    sum += (x[isamLandmarkKey(static_cast<Key>(j))].point - lg.points[j]).squaredNorm();
  }
  out.landmark_error = std::sqrt(sum / std::max<size_t>(1, lg.points.size()));
  return out;
}

Solved solveBatchFile(const sim::LandmarkGraph& lg, const GraphFile& g) {
  auto init = odometryInitialization(g);
  EXPECT_TRUE(init.ok()) << init.error().message;
  auto graph = buildPoseGraph(g, *init, BuildOptions{});
  EXPECT_TRUE(graph.ok()) << graph.error().message;
  const BatchSummary s = solveBatch(*graph, BatchOptions{});
  EXPECT_TRUE(s.ok()) << s.message;
  return compare(lg, *graph, graph->values(), s);
}

Solved solveIncrementalFile(const sim::LandmarkGraph& lg, const GraphFile& g) {
  OnlineRunner runner(g, OnlineOptions{});
  while (!runner.done()) {
    auto r = runner.step();
    EXPECT_TRUE(r.ok()) << r.error().message;
    if (!r.ok()) return {};
  }
  const BatchSummary s = runner.solver().optimize(BatchOptions{});
  EXPECT_TRUE(s.ok()) << s.message;
  return compare(lg, runner.solver().graph(), runner.solver().estimate(), s);
}

sim::LandmarkGraphOptions noiseFree(sim::LandmarkGraphOptions o) {
  o.odometry_sigma_m = o.odometry_sigma_rad = o.point_sigma_m = 0.0;
  return o;
}

TEST(SolverLandmarks, NoiseFreeCityTreesAndTorusPointsAreSolvedToTheTruth) {
  sim::LandmarkGraphOptions o;
  o.poses = 400;
  o.landmarks = 60;
  for (const auto& lg : {sim::cityTreesLike(noiseFree(o)), sim::torusPointsLike(noiseFree(o))}) {
    ASSERT_GT(lg.observations, 50);
    const GraphFile g = readGenerated(lg, "exact.txt");
    EXPECT_EQ(static_cast<int>(g.observations.size()), lg.observations);
    for (const Solved& s : {solveBatchFile(lg, g), solveIncrementalFile(lg, g)}) {
      EXPECT_TRUE(s.converged);
      EXPECT_LT(s.sse, 1e-12);
      EXPECT_LT(s.pose_error, 1e-6);
      EXPECT_LT(s.landmark_error, 1e-6);
    }
  }
}

// With noise the minimum's weighted SSE is a χ² sample with dof = rows − unknowns (mean dof,
// standard deviation sqrt(2 dof)); the estimation error δ is within noise when ‖J δ‖² (the
// SSE of the truth minus that of the estimate) is a χ² sample with `unknowns` degrees of
// freedom; and the incremental run ends at the batch solve's minimum.
void expectSolvedWithinNoise(const sim::LandmarkGraph& lg, double max_pose_m,
                             double max_landmark_m) {
  const GraphFile g = readGenerated(lg, "noisy.txt");
  const Solved batch = solveBatchFile(lg, g);
  const Solved inc = solveIncrementalFile(lg, g);
  ASSERT_GT(batch.dof, 100);
  const double sd = std::sqrt(2.0 * batch.dof);
  EXPECT_NEAR(batch.sse, batch.dof, 4.0 * sd) << "dof " << batch.dof;
  EXPECT_NEAR(batch.truth_excess, batch.unknowns, 4.0 * std::sqrt(2.0 * batch.unknowns));
  EXPECT_TRUE(batch.converged);
  EXPECT_TRUE(inc.converged);
  EXPECT_NEAR(inc.sse, batch.sse, 1e-8 * batch.sse);
  EXPECT_LT(batch.pose_error, max_pose_m);
  EXPECT_LT(batch.landmark_error, max_landmark_m);
  EXPECT_NEAR(inc.pose_error, batch.pose_error, 1e-5);
  std::printf(
      "[ figures  ] %d-D: %d poses, %d landmarks, %d observations: SSE %.6f (dof %lld), "
      "batch %d iterations, incremental SSE %.6f (final %d iterations), SSE(truth) - "
      "SSE %.1f (%d unknowns), max pose error %.3f m, landmark RMS %.3f m\n",
      lg.dimension, static_cast<int>(lg.dimension == 2 ? lg.poses2.size() : lg.poses3.size()),
      lg.observed_landmarks, lg.observations, batch.sse, static_cast<long long>(batch.dof),
      batch.iterations, inc.sse, inc.iterations, batch.truth_excess, batch.unknowns,
      batch.pose_error, batch.landmark_error);
}

TEST(SolverLandmarks, CityTreesLikeProblemConvergesToTheTruthWithinNoiseBatchAndIncremental) {
  // Loose bounds in metres as a sanity check (1000 steps with 0.01 rad heading noise drift
  // by metres without the landmarks); the χ² test above is the real one.
  expectSolvedWithinNoise(sim::cityTreesLike(sim::cityTreesOptions(1000)), 2.0, 1.0);
}

TEST(SolverLandmarks, TorusPointsLikeProblemConvergesToTheTruthWithinNoiseBatchAndIncremental) {
  expectSolvedWithinNoise(sim::torusPointsLike(sim::torusPointsOptions(1000)), 2.5, 1.5);
}

TEST(SolverLandmarks, G2oWriterRoundTripsLandmarksWithTheSameCost) {
  sim::LandmarkGraphOptions o;
  o.poses = 200;
  o.landmarks = 40;
  for (const auto& lg : {sim::cityTreesLike(o), sim::torusPointsLike(o)}) {
    const GraphFile g = readGenerated(lg, "round.txt");
    auto init = odometryInitialization(g);
    ASSERT_TRUE(init.ok()) << init.error().message;
    const fs::path out = fs::temp_directory_path() /
                         ("evermap_solver_landmarks_" + std::to_string(::getpid()) + "_out.g2o");
    ASSERT_TRUE(writeG2o(out, g, *init).ok());
    auto back = readGraphFile(out);
    fs::remove(out);
    ASSERT_TRUE(back.ok()) << back.error().message;
    EXPECT_EQ(back->observations.size(), g.observations.size());
    EXPECT_EQ(back->landmarks.size(), static_cast<size_t>(g.numLandmarks()));
    auto file_init = fileInitialization(*back);
    ASSERT_TRUE(file_init.ok()) << file_init.error().message;
    // Landmark residuals are the same in both formats: their costs agree exactly.
    auto a = buildPoseGraph(g, *init, BuildOptions{});
    auto b = buildPoseGraph(*back, *file_init, BuildOptions{});
    ASSERT_TRUE(a.ok() && b.ok());
    double sa = 0.0, sb = 0.0;
    for (FactorId id = 1 + static_cast<int>(g.edges.size()); id < a->numFactorSlots(); ++id) {
      sa += a->cost(a->values(), id).weighted_sse;
      sb += b->cost(b->values(), id).weighted_sse;
    }
    EXPECT_NEAR(sa, sb, 1e-9 * (1.0 + sa));
  }
}

TEST(SolverLandmarks, FalseLoopClosuresKeepObservationsAfterTheirEdges) {
  sim::LandmarkGraphOptions o;
  o.poses = 300;
  o.landmarks = 50;
  const GraphFile g = readGenerated(sim::cityTreesLike(o), "outliers.txt");
  OutlierOptions oo;
  oo.count = 20;
  oo.mode = OutlierMode::kRandom;
  const GraphFile h = addFalseLoopClosures(g, oo);
  ASSERT_EQ(h.observations.size(), g.observations.size());
  for (size_t k = 0; k < h.observations.size(); ++k) {
    const int before = h.observations[k].edges_before;
    // The observing pose exists after the edges before it (edge before-1 or earlier).
    int file_edges = 0;
    for (int e = 0; e < before; ++e) file_edges += !isSyntheticOutlier(h.edges[e]);
    EXPECT_EQ(file_edges, g.observations[k].edges_before);
  }
  OnlineRunner runner(h, OnlineOptions{});
  while (!runner.done()) ASSERT_TRUE(runner.step().ok());
}

TEST(SolverLandmarks, SeSyncObjectiveRefusesLandmarksNamingTheLine) {
  auto g =
      readGraphText("e.txt", "ODOMETRY 0 1 1 0 0 10 0 0 10 0 20\nLANDMARK 1 0 2.5 -1 5 0.5 4\n");
  ASSERT_TRUE(g.ok());
  auto st = checkInformation(*g, Objective::kSeSync);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().message.find(":2:"), std::string::npos) << st.error().message;
}

}  // namespace
}  // namespace evermap::solver
