// core/solver file formats: g2o, TORO and iSAM readers on good and malformed input, the g2o
// writer round trip, false loop closures and the trajectory error.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>
#include <random>
#include <set>
#include <sstream>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include "core/solver/batch_solver.h"
#include "core/solver/graph_io.h"
#include "core/solver/graph_problem.h"
#include "core/solver/outliers.h"
#include "core/solver/pose_factors.h"
#include "core/solver/trajectory_error.h"

#include "tests/solver_test_util.h"

namespace evermap::solver {
namespace {

using testing::readGraphText;
using testing::TempFile;

namespace fs = std::filesystem;

TEST(GraphIo, ReadsG2o2dVerticesEdgesAndCountsUnknownTags) {
  auto g = readGraphText("a.g2o",
                         "# comment\n"
                         "VERTEX_SE2 0 0 0 0\n"
                         "VERTEX_SE2 1 1.0 0.1 0.2\n"
                         "\n"
                         "EDGE_SE2 0 1 1.0 0.0 0.1 100 0 0 100 0 400\n"
                         "VERTEX_SE2_UNKNOWN 7 1 2\n"
                         "VERTEX_SE2_UNKNOWN 8 1 2\n"
                         "FIX 0\n");
  ASSERT_TRUE(g.ok()) << g.error().message;
  EXPECT_EQ(g->format, GraphFormat::kG2o);
  EXPECT_EQ(g->dimension, 2);
  ASSERT_EQ(g->vertices.size(), 2u);
  ASSERT_EQ(g->edges.size(), 1u);
  EXPECT_EQ(g->skipped_tags.at("VERTEX_SE2_UNKNOWN"), 2);
  EXPECT_EQ(g->skippedLines(), 2);
  EXPECT_EQ(g->fixed, std::vector<Key>{0});
  EXPECT_EQ(g->edges[0].line, 5);
  const Eigen::MatrixXd I = g->edges[0].information();
  EXPECT_NEAR(I(0, 0), 100.0, 1e-9);
  EXPECT_NEAR(I(2, 2), 400.0, 1e-9);
}

TEST(GraphIo, ReadsG2o3dQuaternionEdges) {
  auto g = readGraphText("b.g2o",
                         "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\n"
                         "VERTEX_SE3:QUAT 1 1 0 0 0 0 0.7071068 0.7071068\n"
                         "EDGE_SE3:QUAT 0 1 1 0 0 0 0 0.7071068 0.7071068 "
                         "10 0 0 0 0 0  10 0 0 0 0  10 0 0 0  40 0 0  40 0  40\n");
  ASSERT_TRUE(g.ok()) << g.error().message;
  EXPECT_EQ(g->dimension, 3);
  const core::SE3d& z = g->edges[0].measurement.se3;
  EXPECT_NEAR(yawPitchRoll(z.rotationMatrix())[0], 1.5707963, 1e-6);
  EXPECT_NEAR(g->edges[0].information()(5, 5), 40.0, 1e-9);
}

TEST(GraphIo, MalformedLinesAreErrorsNamingFileAndLine) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"VERTEX_SE2 0 0 0 0\nEDGE_SE2 0 1 1.0 0.0 0.1 100 0 0 100 0\n", ":2:"},      // short
      {"VERTEX_SE2 0 0 0 0\nEDGE_SE2 0 x 1.0 0.0 0.1 100 0 0 100 0 400\n", ":2:"},  // id
      {"EDGE_SE2 0 1 1.0 abc 0.1 100 0 0 100 0 400\n", ":1:"},                      // number
      {"EDGE_SE2 0 1 1.0 nan 0.1 100 0 0 100 0 400\n", ":1:"},                      // NaN
      {"EDGE_SE2 0 1 1.0 0.0 0.1 100 0 0 100 0 400 7\n", ":1:"},                    // long
      {"VERTEX_SE2 0 0 0 0\nVERTEX_SE2 0 1 0 0\n", ":2:"},                          // duplicate
  };
  for (size_t k = 0; k < cases.size(); ++k) {
    TempFile f("bad" + std::to_string(k) + ".g2o", cases[k].first);
    auto g = readGraphFile(f.path(), GraphFormat::kG2o);
    ASSERT_FALSE(g.ok()) << "case " << k;
    EXPECT_NE(g.error().message.find(f.path().string() + cases[k].second), std::string::npos)
        << g.error().message;
  }
  EXPECT_FALSE(readGraphFile("/nonexistent/graph.g2o").ok());
}

TEST(GraphIo, ToroInformationUsesToroOrdering) {
  // EDGE2 i j x y θ Ixx Ixy Iyy Iθθ Ixθ Iyθ.
  auto g = readGraphText(
      "c.graph", "VERTEX2 0 0 0 0\nVERTEX2 1 1 0 0\nEDGE2 0 1 1 0 0 10 1 20 30 2 3\nEQUIV 0 1\n");
  ASSERT_TRUE(g.ok()) << g.error().message;
  EXPECT_EQ(g->format, GraphFormat::kToro);
  const Eigen::MatrixXd I = g->edges[0].information();
  EXPECT_NEAR(I(0, 0), 10, 1e-9);
  EXPECT_NEAR(I(0, 1), 1, 1e-9);
  EXPECT_NEAR(I(1, 1), 20, 1e-9);
  EXPECT_NEAR(I(2, 2), 30, 1e-9);
  EXPECT_NEAR(I(0, 2), 2, 1e-9);
  EXPECT_NEAR(I(1, 2), 3, 1e-9);
  EXPECT_EQ(g->skipped_tags.at("EQUIV"), 1);
}

TEST(GraphIo, IsamFormatReadsSquareRootInformationAndRollPitchYawAngles) {
  auto g2 =
      readGraphText("d.txt", "ODOMETRY 0 1 1 0 0.1 2 0 0 3 0 4\nEDGE2 0 1 1 0 0.1 2 0.5 0 3 0 4\n");
  ASSERT_TRUE(g2.ok()) << g2.error().message;
  EXPECT_EQ(g2->format, GraphFormat::kIsam);
  EXPECT_NEAR(g2->edges[0].sqrt_information(1, 1), 3.0, 1e-12);
  EXPECT_NEAR(g2->edges[1].sqrt_information(0, 1), 0.5, 1e-12);
  EXPECT_NEAR(g2->edges[1].information()(0, 0), 4.0, 1e-12);
  // EDGE3 x y z roll pitch yaw; square root in (x, y, z, roll, pitch, yaw) order in the file,
  // stored as iSAM's (x, y, z, yaw, pitch, roll).
  auto g3 = readGraphText(
      "e.txt", "EDGE3 0 1 1 2 3 0.1 0.2 0.3 1 0 0 0 0 0 2 0 0 0 0 3 0 0 0 4 0 0 5 0 6\n");
  ASSERT_TRUE(g3.ok()) << g3.error().message;
  const core::Vec3 ypr = yawPitchRoll(g3->edges[0].measurement.se3.rotationMatrix());
  EXPECT_NEAR(ypr[0], 0.3, 1e-12);
  EXPECT_NEAR(ypr[1], 0.2, 1e-12);
  EXPECT_NEAR(ypr[2], 0.1, 1e-12);
  const Eigen::MatrixXd& S = g3->edges[0].sqrt_information;
  EXPECT_EQ(S(3, 3), 6.0);  // yaw
  EXPECT_EQ(S(4, 4), 5.0);  // pitch
  EXPECT_EQ(S(5, 5), 4.0);  // roll
  auto b = readGraphText("f.txt", "ODOMETRY 0 1 1 0 0.1 2 0 0 0 0 4\n");
  ASSERT_FALSE(b.ok());
  EXPECT_NE(b.error().message.find(":1:"), std::string::npos);
}

TEST(GraphIo, G2oWriterRoundTripsVerticesAndEdges) {
  auto g = readGraphText("g.g2o",
                         "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1.0 0.1 0.2\n"
                         "EDGE_SE2 0 1 1.0 0.0 0.1 100 5 0 100 0 400\n");
  ASSERT_TRUE(g.ok());
  auto v = fileInitialization(*g);
  ASSERT_TRUE(v.ok());
  const fs::path out =
      fs::temp_directory_path() / ("evermap_solver_io_out_" + std::to_string(::getpid()) + ".g2o");
  ASSERT_TRUE(writeG2o(out, *g, *v).ok());
  auto back = readGraphFile(out);
  fs::remove(out);
  ASSERT_TRUE(back.ok()) << back.error().message;
  ASSERT_EQ(back->vertices.size(), 2u);
  EXPECT_NEAR(back->vertices[1].pose.se2.theta(), 0.2, 1e-15);
  EXPECT_TRUE(back->edges[0].information().isApprox(g->edges[0].information(), 1e-12));
  EXPECT_FALSE(writeG2o("/nonexistent/dir/x.g2o", *g, *v).ok());
}

TEST(GraphIo, IsamEdgesWrittenAsG2oKeepTheirCostToFirstOrder) {
  // A 2-D iSAM edge and its g2o rewrite give the same χ² near the measurement.
  auto g = readGraphText("h.txt", "ODOMETRY 0 1 1 0.5 0.7 2 0.3 0.1 3 0.2 4\n");
  ASSERT_TRUE(g.ok());
  const fs::path out =
      fs::temp_directory_path() / ("evermap_solver_io_h_" + std::to_string(::getpid()) + ".g2o");
  Values v;
  v.add(0, PoseValue::planar(core::SE2d()));
  v.add(1, PoseValue::planar(core::SE2d(1.01, 0.49, 0.71)));
  ASSERT_TRUE(writeG2o(out, *g, v).ok());
  auto back = readGraphFile(out);
  fs::remove(out);
  ASSERT_TRUE(back.ok());
  const PoseValue* x[2] = {&v.at(0), &v.at(1)};
  auto chi2 = [&](const GraphFile& file) {
    auto f = makeEdgeFactor(file, file.edges[0], Objective::kNative);
    Eigen::Vector3d r;
    f->evaluate(x, r.data(), nullptr);
    return (f->sqrtInformation() * r).squaredNorm();
  };
  EXPECT_NEAR(chi2(*back), chi2(*g), 1e-9);
}

// A 3-D g2o file along a path with loop closures whose 6x6 information is
// [[a I, c I], [c I, b I]]: indefinite for c² > ab although both blocks are definite.
std::string coupledInformationGraph(double c) {
  std::ostringstream out;
  out.precision(17);
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 0.02);
  auto edge = [&](int from, int to, double n, double c) {
    Eigen::Quaterniond q(Eigen::AngleAxisd(0.3 * n + noise(rng), Eigen::Vector3d::UnitZ()));
    out << "EDGE_SE3:QUAT " << from << ' ' << to << ' ' << n + noise(rng) << ' ' << noise(rng)
        << ' ' << noise(rng) << ' ' << q.x() << ' ' << q.y() << ' ' << q.z() << ' ' << q.w();
    Eigen::Matrix<double, 6, 6> I = Eigen::Matrix<double, 6, 6>::Zero();
    I.topLeftCorner<3, 3>() = 100.0 * Eigen::Matrix3d::Identity();
    I.bottomRightCorner<3, 3>() = 400.0 * Eigen::Matrix3d::Identity();
    I.topRightCorner<3, 3>() = c * Eigen::Matrix3d::Identity();
    I.bottomLeftCorner<3, 3>() = c * Eigen::Matrix3d::Identity();
    for (int r = 0; r < 6; ++r) {
      for (int k = r; k < 6; ++k) out << ' ' << I(r, k);
    }
    out << '\n';
  };
  // Odometry i → i+1, then for i = 6, 9, ..., 27 a loop closure i−6 → i (line 8 is 0-6).
  for (int i = 0; i < 30; ++i) {
    edge(i, i + 1, 1.0, 0.0);
    if (i >= 6 && i % 3 == 0) edge(i - 6, i, 6.0, c);
  }
  return out.str();
}

// coupledInformationGraph(300) read from a file named `name` and its indefinite matrices
// resolved by `rule`: all 8 change and the native objective then takes them.
void readResolved(const std::string& name, IndefiniteInformation rule, GraphFile* out) {
  auto g = readGraphText(name, coupledInformationGraph(300.0));
  ASSERT_TRUE(g.ok());
  auto changed = resolveIndefiniteInformation(&*g, rule);
  ASSERT_TRUE(changed.ok()) << changed.error().message;
  EXPECT_EQ(*changed, 8);
  EXPECT_TRUE(checkInformation(*g, Objective::kNative).ok());
  *out = std::move(*g);
}

TEST(GraphIo, IndefiniteInformationIsReadAndRefusedNamingTheEdge) {
  TempFile f("indefinite.g2o", coupledInformationGraph(300.0));  // 300² > 100·400
  auto g = readGraphFile(f.path());
  ASSERT_TRUE(g.ok()) << g.error().message;
  int indefinite = 0;
  for (const GraphEdge& e : g->edges) indefinite += !e.positiveDefinite();
  EXPECT_EQ(indefinite, 8);
  const GraphEdge& first = g->edges[7];  // line 8: the loop 0-6
  ASSERT_FALSE(first.positiveDefinite());
  EXPECT_NEAR(first.information()(0, 3), 300.0, 1e-9);
  const Status native = checkInformation(*g, Objective::kNative);
  ASSERT_FALSE(native.ok());
  EXPECT_NE(native.error().message.find(f.path().string() + ":8: edge 0-6"), std::string::npos)
      << native.error().message;
  GraphFile copy = *g;
  auto refused = resolveIndefiniteInformation(&copy, IndefiniteInformation::kRefuse);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.error().message.find(":8: edge 0-6"), std::string::npos);
  // Per axis [[100, 300], [300, 400]]: smallest eigenvalue 250 − √(150² + 300²) = −85.41.
  EXPECT_NE(refused.error().message.find("eigenvalue -85.4"), std::string::npos)
      << refused.error().message;
}

TEST(GraphIo, BlocksRuleDropsOnlyTheCouplingOfTranslationAndRotation) {
  GraphFile g;
  ASSERT_NO_FATAL_FAILURE(readResolved("blocks.g2o", IndefiniteInformation::kBlocks, &g));
  const Eigen::MatrixXd I = g.edges[7].information();
  EXPECT_NEAR(I(0, 0), 100.0, 1e-9);
  EXPECT_NEAR(I(5, 5), 400.0, 1e-9);
  EXPECT_NEAR(I.topRightCorner(3, 3).norm(), 0.0, 1e-9);
}

TEST(GraphIo, NearestPositiveDefiniteRaisesOnlyTheEigenvaluesBelowTheFloor) {
  Eigen::MatrixXd I(3, 3);
  I << 4, 3, 0, 3, 1, 0, 0, 0, 2;  // eigenvalues 2, 2.5 ± √(2.25 + 9) → 5.854, −0.854
  const Eigen::MatrixXd P = nearestPositiveDefinite(I, 1e-6);
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> before(I), after(P);
  EXPECT_NEAR(after.eigenvalues()[0], 1e-6 * before.eigenvalues()[2], 1e-12);
  EXPECT_NEAR(after.eigenvalues()[1], before.eigenvalues()[1], 1e-12);
  EXPECT_NEAR(after.eigenvalues()[2], before.eigenvalues()[2], 1e-12);
  // Nearest in the Frobenius norm: the distance is what the clipped eigenvalue moved.
  EXPECT_NEAR((P - I).norm(), 1e-6 * before.eigenvalues()[2] - before.eigenvalues()[0], 1e-12);
  GraphFile g;
  ASSERT_NO_FATAL_FAILURE(readResolved("nearest.g2o", IndefiniteInformation::kNearest, &g));
}

TEST(GraphProblem, SeSyncObjectiveUsesOnlyTheBlocksOfAnIndefiniteMatrix) {
  // The same graph with an indefinite coupling and with none: SE-Sync's weights come from
  // the blocks, so both reach the same minimum of f.
  TempFile coupled("coupled.g2o", coupledInformationGraph(300.0));
  TempFile plain("plain.g2o", coupledInformationGraph(0.0));
  std::vector<double> minima;
  for (const fs::path& p : {coupled.path(), plain.path()}) {
    auto g = readGraphFile(p);
    ASSERT_TRUE(g.ok());
    ASSERT_TRUE(checkInformation(*g, Objective::kSeSync).ok());
    auto init = chordalInitialization(*g);
    ASSERT_TRUE(init.ok());
    BuildOptions b;
    b.objective = Objective::kSeSync;
    auto graph = buildPoseGraph(*g, *init, b);
    ASSERT_TRUE(graph.ok()) << graph.error().message;
    const BatchSummary s = solveBatch(*graph, BatchOptions{});
    EXPECT_TRUE(s.converged()) << s.message;
    minima.push_back(seSyncCost(*g, graph->values()));
  }
  EXPECT_GT(minima[0], 0.0);
  EXPECT_NEAR(minima[0], minima[1], 1e-9 * minima[1]);
  // The native objective refuses the indefinite file rather than building a factor.
  auto g = readGraphFile(coupled.path());
  auto init = chordalInitialization(*g);
  EXPECT_FALSE(buildPoseGraph(*g, *init, BuildOptions{}).ok());
}

TEST(Outliers, AreInsertedAfterBothPosesExistWithRealLoopInformation) {
  GraphFile g;
  g.dimension = 2;
  g.format = GraphFormat::kIsam;
  for (int i = 0; i < 50; ++i) {
    GraphEdge e;
    e.from = i;
    e.to = i + 1;
    e.measurement = PoseValue::planar(core::SE2d(1, 0, 0));
    e.sqrt_information = Eigen::MatrixXd::Identity(3, 3);
    e.line = i + 1;
    g.edges.push_back(e);
    if (i % 10 == 9) {
      e.from = i - 5;
      e.sqrt_information = 7.0 * Eigen::MatrixXd::Identity(3, 3);
      g.edges.push_back(e);
    }
  }
  const GraphFile o = addFalseLoopClosures(g, OutlierOptions{20, 3});
  ASSERT_EQ(o.edges.size(), g.edges.size() + 20);
  std::set<Key> seen = {0};
  int synthetic = 0;
  for (const GraphEdge& e : o.edges) {
    if (isSyntheticOutlier(e)) {
      ++synthetic;
      EXPECT_TRUE(seen.count(e.from) && seen.count(e.to)) << "outlier before its poses exist";
      EXPECT_EQ(e.sqrt_information(0, 0), 7.0);
      EXPECT_GT(std::abs(e.to - e.from), 1);
    }
    seen.insert(e.from);
    seen.insert(e.to);
  }
  EXPECT_EQ(synthetic, 20);
  // The same seed gives the same outliers.
  const GraphFile o2 = addFalseLoopClosures(g, OutlierOptions{20, 3});
  for (size_t i = 0; i < o.edges.size(); ++i) EXPECT_EQ(o.edges[i].from, o2.edges[i].from);
}

TEST(TrajectoryError, IsZeroForARigidlyMovedCopyAndMeasuresOffsets) {
  Values truth;
  Values moved;
  const core::SE2d T(3.0, -1.0, 0.8);
  for (int i = 0; i < 10; ++i) {
    const core::SE2d p(i * 0.7, std::sin(i), 0.1 * i);
    truth.add(i, PoseValue::planar(p));
    moved.add(i, PoseValue::planar(T * p));
  }
  auto e = absoluteTrajectoryError(moved, truth);
  ASSERT_TRUE(e.ok());
  EXPECT_LT(e->rmse_m, 1e-12);
  EXPECT_EQ(e->matched, 10);
  moved.at(4) = PoseValue::planar(T * core::SE2d(4 * 0.7, std::sin(4) + 1.0, 0.4));
  EXPECT_GT(absoluteTrajectoryError(moved, truth)->rmse_m, 0.1);
  EXPECT_FALSE(absoluteTrajectoryError(Values(), truth).ok());
}

}  // namespace
}  // namespace evermap::solver

namespace evermap::solver {
namespace {

GraphFile chainWithLoops(int n) {
  GraphFile g;
  g.dimension = 2;
  g.format = GraphFormat::kG2o;
  for (int i = 0; i + 1 < n; ++i) {
    GraphEdge e;
    e.from = i;
    e.to = i + 1;
    e.measurement = PoseValue::planar(core::SE2d(1.0, 0.0, 0.1 * std::sin(0.3 * i)));
    e.sqrt_information = Eigen::MatrixXd::Identity(3, 3);
    e.line = i + 1;
    g.edges.push_back(e);
    if (i >= 10 && i % 10 == 0) {
      e.from = i - 10;
      e.sqrt_information = 7.0 * Eigen::MatrixXd::Identity(3, 3);
      g.edges.push_back(e);
    }
  }
  return g;
}

// The `count` false closures of `mode` that addFalseLoopClosures adds to g.
std::vector<GraphEdge> falseClosures(const GraphFile& g, OutlierMode mode, int count) {
  OutlierOptions o;
  o.count = count;
  o.mode = mode;
  std::vector<GraphEdge> out;
  for (const GraphEdge& e : addFalseLoopClosures(g, o).edges) {
    if (isSyntheticOutlier(e)) out.push_back(e);
  }
  return out;
}

TEST(Outliers, RandomClosuresCarryVertigosMeasurementSpread) {
  const GraphFile g = chainWithLoops(300);
  const auto edges = falseClosures(g, OutlierMode::kRandom, 2000);
  ASSERT_EQ(edges.size(), 2000u);
  double sx = 0.0, st = 0.0;
  int far = 0;
  for (const GraphEdge& e : edges) {
    sx += e.measurement.se2.x() * e.measurement.se2.x();
    st += e.measurement.se2.theta() * e.measurement.se2.theta();
    far += e.to - e.from > 20;
  }
  EXPECT_NEAR(std::sqrt(sx / edges.size()), 3.0, 0.15);
  EXPECT_NEAR(std::sqrt(st / edges.size()), 10.0 * std::numbers::pi / 180.0, 0.01);
  EXPECT_GT(far, 1500) << "random pairs span the whole trajectory";
}

TEST(Outliers, LocalClosuresJoinPosesAtMostTwentyApart) {
  const GraphFile g = chainWithLoops(300);
  const auto edges = falseClosures(g, OutlierMode::kLocal, 200);
  ASSERT_EQ(edges.size(), 200u);
  std::set<Key> gaps;
  for (const GraphEdge& e : edges) {
    EXPECT_GE(e.to - e.from, 2);
    EXPECT_LE(e.to - e.from, 20);
    gaps.insert(e.to - e.from);
  }
  EXPECT_GT(gaps.size(), 10u) << "the gap is drawn, not fixed";
}

TEST(Outliers, AGroupAgreesOnOneFalseRelativePoseBetweenTwoStretches) {
  const GraphFile g = chainWithLoops(300);
  const auto edges = falseClosures(g, OutlierMode::kGroup, 30);
  ASSERT_EQ(edges.size(), 30u);
  // Group by the first pose of the stretch: members k of a group join a + k and b + k.
  std::map<Key, std::vector<GraphEdge>> groups;  // by b − a (distinct groups: distinct gaps)
  for (const GraphEdge& e : edges) groups[e.to - e.from].push_back(e);
  ASSERT_EQ(groups.size(), 3u);
  std::map<Key, core::SE2d> world;  // odometry-chained poses
  core::SE2d x;
  world[0] = x;
  for (const GraphEdge& e : g.edges) {
    if (e.to == e.from + 1) world[e.to] = world[e.from] * e.measurement.se2;
  }
  for (const auto& [gap, members] : groups) {
    ASSERT_EQ(members.size(), 10u);
    Key a0 = members[0].from;
    for (const GraphEdge& e : members) a0 = std::min(a0, e.from);
    std::set<Key> firsts;
    // Every member implies the same a0_T_b0 = a0_T_ak · z_k · (b0_T_bk)⁻¹.
    const Key b0 = a0 + gap;
    std::vector<core::SE2d> implied;
    for (const GraphEdge& e : members) {
      firsts.insert(e.from);
      const core::SE2d a0_T_ak = world[a0].inverse() * world[e.from];
      const core::SE2d b0_T_bk = world[b0].inverse() * world[e.to];
      implied.push_back(a0_T_ak * e.measurement.se2 * b0_T_bk.inverse());
    }
    EXPECT_EQ(firsts.size(), 10u);
    EXPECT_EQ(*firsts.rbegin() - *firsts.begin(), 9) << "consecutive poses";
    for (const core::SE2d& T : implied) {
      EXPECT_NEAR(T.x(), implied[0].x(), 1e-9);
      EXPECT_NEAR(T.y(), implied[0].y(), 1e-9);
      EXPECT_NEAR(core::wrapAngle(T.theta() - implied[0].theta()), 0.0, 1e-9);
    }
  }
}

TEST(Outliers, ParsesModeNames) {
  EXPECT_EQ(*parseOutlierMode("random"), OutlierMode::kRandom);
  EXPECT_EQ(*parseOutlierMode("local"), OutlierMode::kLocal);
  EXPECT_EQ(*parseOutlierMode("group"), OutlierMode::kGroup);
  EXPECT_FALSE(parseOutlierMode("clustered").ok());
}

}  // namespace
}  // namespace evermap::solver
