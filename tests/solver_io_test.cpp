// core/solver file formats: g2o, TORO and iSAM readers on good and malformed input, the g2o
// writer round trip, false loop closures and the trajectory error.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>

#include "core/solver/graph_io.h"
#include "core/solver/graph_problem.h"
#include "core/solver/outliers.h"
#include "core/solver/pose_factors.h"
#include "core/solver/trajectory_error.h"

namespace evermap::solver {
namespace {

namespace fs = std::filesystem;

class TempFile {
 public:
  TempFile(const std::string& name, const std::string& content)
      : path_(fs::temp_directory_path() / ("evermap_solver_io_" + std::to_string(::getpid()) + "_" + name)) {
    std::ofstream(path_) << content;
  }
  ~TempFile() { fs::remove(path_); }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

TEST(GraphIo, ReadsG2o2dVerticesEdgesAndCountsUnknownTags) {
  TempFile f("a.g2o",
             "# comment\n"
             "VERTEX_SE2 0 0 0 0\n"
             "VERTEX_SE2 1 1.0 0.1 0.2\n"
             "\n"
             "EDGE_SE2 0 1 1.0 0.0 0.1 100 0 0 100 0 400\n"
             "VERTEX_XY 7 1 2\n"
             "VERTEX_XY 8 1 2\n"
             "FIX 0\n");
  auto g = readGraphFile(f.path());
  ASSERT_TRUE(g.ok()) << g.error().message;
  EXPECT_EQ(g->format, GraphFormat::kG2o);
  EXPECT_EQ(g->dimension, 2);
  ASSERT_EQ(g->vertices.size(), 2u);
  ASSERT_EQ(g->edges.size(), 1u);
  EXPECT_EQ(g->skipped_tags.at("VERTEX_XY"), 2);
  EXPECT_EQ(g->skippedLines(), 2);
  EXPECT_EQ(g->fixed, std::vector<Key>{0});
  EXPECT_EQ(g->edges[0].line, 5);
  const Eigen::MatrixXd I = g->edges[0].information();
  EXPECT_NEAR(I(0, 0), 100.0, 1e-9);
  EXPECT_NEAR(I(2, 2), 400.0, 1e-9);
}

TEST(GraphIo, ReadsG2o3dQuaternionEdges) {
  TempFile f("b.g2o",
             "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\n"
             "VERTEX_SE3:QUAT 1 1 0 0 0 0 0.7071068 0.7071068\n"
             "EDGE_SE3:QUAT 0 1 1 0 0 0 0 0.7071068 0.7071068 "
             "10 0 0 0 0 0  10 0 0 0 0  10 0 0 0  40 0 0  40 0  40\n");
  auto g = readGraphFile(f.path());
  ASSERT_TRUE(g.ok()) << g.error().message;
  EXPECT_EQ(g->dimension, 3);
  const core::SE3d& z = g->edges[0].measurement.se3;
  EXPECT_NEAR(yawPitchRoll(z.rotationMatrix())[0], 1.5707963, 1e-6);
  EXPECT_NEAR(g->edges[0].information()(5, 5), 40.0, 1e-9);
}

TEST(GraphIo, MalformedLinesAreErrorsNamingFileAndLine) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"VERTEX_SE2 0 0 0 0\nEDGE_SE2 0 1 1.0 0.0 0.1 100 0 0 100 0\n", ":2:"},        // short
      {"VERTEX_SE2 0 0 0 0\nEDGE_SE2 0 x 1.0 0.0 0.1 100 0 0 100 0 400\n", ":2:"},    // id
      {"EDGE_SE2 0 1 1.0 abc 0.1 100 0 0 100 0 400\n", ":1:"},                        // number
      {"EDGE_SE2 0 1 1.0 nan 0.1 100 0 0 100 0 400\n", ":1:"},                        // NaN
      {"EDGE_SE2 0 1 1.0 0.0 0.1 100 0 0 -100 0 400\n", ":1:"},                       // not PD
      {"VERTEX_SE2 0 0 0 0\nVERTEX_SE2 0 1 0 0\n", ":2:"},                             // duplicate
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
  TempFile f("c.graph",
             "VERTEX2 0 0 0 0\nVERTEX2 1 1 0 0\nEDGE2 0 1 1 0 0 10 1 20 30 2 3\nEQUIV 0 1\n");
  auto g = readGraphFile(f.path());
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
  TempFile f2("d.txt", "ODOMETRY 0 1 1 0 0.1 2 0 0 3 0 4\nEDGE2 0 1 1 0 0.1 2 0.5 0 3 0 4\n");
  auto g2 = readGraphFile(f2.path());
  ASSERT_TRUE(g2.ok()) << g2.error().message;
  EXPECT_EQ(g2->format, GraphFormat::kIsam);
  EXPECT_NEAR(g2->edges[0].sqrt_information(1, 1), 3.0, 1e-12);
  EXPECT_NEAR(g2->edges[1].sqrt_information(0, 1), 0.5, 1e-12);
  EXPECT_NEAR(g2->edges[1].information()(0, 0), 4.0, 1e-12);
  // EDGE3 x y z roll pitch yaw; square root in (x, y, z, roll, pitch, yaw) order in the file,
  // stored as iSAM's (x, y, z, yaw, pitch, roll).
  TempFile f3("e.txt",
              "EDGE3 0 1 1 2 3 0.1 0.2 0.3 1 0 0 0 0 0 2 0 0 0 0 3 0 0 0 4 0 0 5 0 6\n");
  auto g3 = readGraphFile(f3.path());
  ASSERT_TRUE(g3.ok()) << g3.error().message;
  const core::Vec3 ypr = yawPitchRoll(g3->edges[0].measurement.se3.rotationMatrix());
  EXPECT_NEAR(ypr[0], 0.3, 1e-12);
  EXPECT_NEAR(ypr[1], 0.2, 1e-12);
  EXPECT_NEAR(ypr[2], 0.1, 1e-12);
  const Eigen::MatrixXd& S = g3->edges[0].sqrt_information;
  EXPECT_EQ(S(3, 3), 6.0);  // yaw
  EXPECT_EQ(S(4, 4), 5.0);  // pitch
  EXPECT_EQ(S(5, 5), 4.0);  // roll
  TempFile bad("f.txt", "ODOMETRY 0 1 1 0 0.1 2 0 0 0 0 4\n");
  auto b = readGraphFile(bad.path());
  ASSERT_FALSE(b.ok());
  EXPECT_NE(b.error().message.find(":1:"), std::string::npos);
}

TEST(GraphIo, G2oWriterRoundTripsVerticesAndEdges) {
  TempFile in("g.g2o",
              "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1.0 0.1 0.2\n"
              "EDGE_SE2 0 1 1.0 0.0 0.1 100 5 0 100 0 400\n");
  auto g = readGraphFile(in.path());
  ASSERT_TRUE(g.ok());
  auto v = fileInitialization(*g);
  ASSERT_TRUE(v.ok());
  const fs::path out = fs::temp_directory_path() / ("evermap_solver_io_out_" + std::to_string(::getpid()) + ".g2o");
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
  TempFile in("h.txt", "ODOMETRY 0 1 1 0.5 0.7 2 0.3 0.1 3 0.2 4\n");
  auto g = readGraphFile(in.path());
  ASSERT_TRUE(g.ok());
  const fs::path out = fs::temp_directory_path() / ("evermap_solver_io_h_" + std::to_string(::getpid()) + ".g2o");
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
