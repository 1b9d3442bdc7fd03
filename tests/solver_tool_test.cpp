// evermap-solver as a process: the status line printed last and the exit status tell whether
// the optimisation converged (0) or ran out of its iteration budget (3); an indefinite
// information matrix is refused naming the edge unless a rule is chosen; landmark lines are
// solved, not dropped, and a malformed one is a one-line error naming file:line.
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "tools/sim/landmark_graphs.h"

namespace {

namespace fs = std::filesystem;
const fs::path kSolver = fs::path(EVERMAP_BINARY_DIR) / "bin" / "evermap-solver";

struct ToolRun {
  int exit_status = -1;
  std::string output;
  std::string lastLine() const {
    std::istringstream in(output);
    std::string line, last;
    while (std::getline(in, line)) {
      if (!line.empty()) last = line;
    }
    return last;
  }
};

ToolRun run(const std::string& args) {
  ToolRun r;
  const std::string cmd = kSolver.string() + " " + args + " 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return r;
  std::array<char, 4096> buf;
  size_t n;
  while ((n = fread(buf.data(), 1, buf.size(), p)) > 0) r.output.append(buf.data(), n);
  const int st = pclose(p);
  r.exit_status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

// A planar square path with loop closures, measurements off the truth by a fixed pattern,
// far enough from odometry chaining that one Gauss-Newton step does not converge.
fs::path writeGraph(const std::string& name, bool indefinite_loop) {
  const fs::path path = fs::temp_directory_path() /
                        ("evermap_solver_tool_" + std::to_string(::getpid()) + "_" + name);
  std::ofstream out(path);
  for (int i = 0; i < 40; ++i) {
    const double turn = (i % 5 == 4) ? 1.5707963 : 0.05;
    out << "EDGE_SE2 " << i << ' ' << i + 1 << ' ' << 1.0 + 0.05 * ((i % 3) - 1) << " 0.02 "
        << turn + 0.03 * ((i % 4) - 1.5) << " 100 0 0 100 0 400\n";
  }
  out << "EDGE_SE2 0 20 0.5 0.3 0.2 "
      << (indefinite_loop ? "100 0 300 100 0 400" : "100 0 0 100 0 400") << "\n";
  out << "EDGE_SE2 5 35 -0.5 0.4 0.1 100 0 0 100 0 400\n";
  return path;
}

TEST(SolverTool, ExitsThreeAndSaysSoLastWhenTheBudgetRunsOut) {
  ASSERT_TRUE(fs::exists(kSolver)) << kSolver << " not built";
  const fs::path g = writeGraph("budget.g2o", false);
  for (const std::string mode : {"--batch", ""}) {
    const ToolRun cut = run(mode + " --max-iterations 1 " + g.string());
    EXPECT_EQ(cut.exit_status, 3) << cut.output;
    EXPECT_EQ(cut.lastLine().rfind("status: NOT CONVERGED", 0), 0u) << cut.lastLine();
    const ToolRun full = run(mode + " " + g.string());
    EXPECT_EQ(full.exit_status, 0) << full.output;
    EXPECT_EQ(full.lastLine().rfind("status: converged", 0), 0u) << full.lastLine();
    // The χ² line is the edges' own: the anchor prior is on a separate line.
    EXPECT_NE(full.output.find("final chi2 of the edges"), std::string::npos);
    EXPECT_NE(full.output.find("anchor prior on pose 0"), std::string::npos);
  }
  fs::remove(g);
}

TEST(SolverTool, RefusesAnIndefiniteInformationMatrixUnlessARuleIsChosen) {
  ASSERT_TRUE(fs::exists(kSolver)) << kSolver << " not built";
  const fs::path g = writeGraph("indefinite.g2o", true);
  const ToolRun refused = run("--batch " + g.string());
  EXPECT_EQ(refused.exit_status, 1) << refused.output;
  EXPECT_NE(refused.output.find(g.string() + ":41: edge 0-20"), std::string::npos)
      << refused.output;
  for (const std::string rule : {"blocks", "nearest"}) {
    const ToolRun repaired = run("--batch --indefinite-information " + rule + " " + g.string());
    EXPECT_EQ(repaired.exit_status, 0) << repaired.output;
    EXPECT_NE(repaired.output.find("1 information matrices replaced"), std::string::npos);
  }
  const ToolRun sesync = run("--batch --objective sesync " + g.string());
  EXPECT_EQ(sesync.exit_status, 0) << sesync.output;
  fs::remove(g);
}

double numberAfter(const std::string& text, const std::string& label) {
  const size_t at = text.find(label);
  if (at == std::string::npos) return -1.0;
  return std::stod(text.substr(at + label.size()));
}

TEST(SolverTool, SolvesIsamLandmarkLinesInsteadOfDroppingThem) {
  ASSERT_TRUE(fs::exists(kSolver)) << kSolver << " not built";
  evermap::sim::LandmarkGraphOptions o;
  o.poses = 300;
  o.landmarks = 40;
  const auto lg = evermap::sim::cityTreesLike(o);
  const fs::path path = fs::temp_directory_path() /
                        ("evermap_solver_tool_" + std::to_string(::getpid()) + "_trees.txt");
  std::ofstream(path) << lg.isam_text;
  const ToolRun batch = run("--batch " + path.string());
  const ToolRun inc = run(path.string());
  for (const ToolRun* r : {&batch, &inc}) {
    EXPECT_EQ(r->exit_status, 0) << r->output;
    EXPECT_EQ(r->output.find("skipped"), std::string::npos) << r->output;
    EXPECT_NE(r->output.find(std::to_string(lg.observed_landmarks) + " landmarks, " +
                             std::to_string(lg.observations) + " landmark observations"),
              std::string::npos)
        << r->output;
  }
  const std::string label = "weighted SSE of the edges and landmarks (no 1/2)";
  const double sse_batch = numberAfter(batch.output, label);
  const double sse_inc = numberAfter(inc.output, label);
  EXPECT_GT(sse_batch, 1.0);  // noisy data: not the pose chain alone (≈ 0)
  EXPECT_NEAR(sse_inc, sse_batch, 1e-6 * sse_batch);

  std::ofstream(path) << "ODOMETRY 0 1 1 0 0 10 0 0 10 0 20\nLANDMARK 1 0 2.5 -1 5 0.5\n";
  const ToolRun bad = run(path.string());
  EXPECT_EQ(bad.exit_status, 1);
  EXPECT_EQ(bad.output.rfind(
                "evermap-solver: " + path.string() + ":2: LANDMARK expects 7 fields, got 6", 0),
            0u)
      << bad.output;
  EXPECT_EQ(bad.output.find('\n'), bad.output.size() - 1) << "one line: " << bad.output;
  fs::remove(path);
}

}  // namespace
