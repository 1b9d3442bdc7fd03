// Solver benchmark: for each iSAM data set, the incremental run (Gauss-Newton, update every
// step, batch step every 100, one final batch step — iSAM 1.6's defaults), the batch
// Gauss-Newton solve from odometry, per-step median and p99, peak memory, and the ratio to
// the original iSAM's incremental times in ../shared/data/README.md.
//
//   build/bin/solver_bench                 the table (each data set in its own process, so
//                                          that peak memory is per data set)
//   build/bin/solver_bench --micro         Google Benchmark micro-benchmarks, among them the
//                                          landmark problems (cityTrees-like 2-D and
//                                          torusPoints-like 3-D, generated; batch and
//                                          incremental), 5 repetitions, median reported:
//     build/bin/solver_bench --micro --benchmark_filter=Landmarks
//
// Wall time is what iSAM's figures are; CPU time is printed too because the machine is
// shared (on a loaded machine wall time overstates the solver's own cost).
#include <benchmark/benchmark.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "core/solver/batch_solver.h"
#include "core/solver/graph_problem.h"
#include "core/solver/online_runner.h"
#include "core/solver/process_tuning.h"
#include "core/solver/square_root_factor.h"
#include "tools/sim/landmark_graphs.h"

namespace {

using namespace evermap::solver;

double wall() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}
double cpu() {
  timespec t;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return t.tv_sec + 1e-9 * t.tv_nsec;
}
double peakMb() {
  rusage ru;
  getrusage(RUSAGE_SELF, &ru);
  return ru.ru_maxrss / 1024.0;
}

std::filesystem::path dataRoot() {
  if (const char* e = std::getenv("EVERMAP_DATA"); e && *e) return e;
  return EVERMAP_DATA_DEFAULT;
}

struct Result {
  double wall_s = 0, cpu_s = 0, median_ms = 0, p99_ms = 0, sse = 0, peak_mb = 0;
  int batches = 0;
};

// Runs in a child process; returns false on error.
bool runIncremental(const GraphFile& g, Result* r) {
  OnlineOptions o;
  OnlineRunner runner(g, o);
  std::vector<double> steps;
  const double w0 = wall();
  const double c0 = cpu();
  while (!runner.done()) {
    const double t = wall();
    auto s = runner.step();
    if (!s.ok()) {
      std::fprintf(stderr, "%s\n", s.error().message.c_str());
      return false;
    }
    steps.push_back(wall() - t);
    r->batches += s->batch;
  }
  if (!runner.finish().ok()) return false;
  r->wall_s = wall() - w0;
  r->cpu_s = cpu() - c0;
  std::sort(steps.begin(), steps.end());
  r->median_ms = 1e3 * steps[steps.size() / 2];
  r->p99_ms = 1e3 * steps[std::min(steps.size() - 1, steps.size() * 99 / 100)];
  r->sse = runner.solver().cost().weighted_sse;
  r->peak_mb = peakMb();
  return true;
}

bool runBatch(const GraphFile& g, Result* r) {
  const double w0 = wall();
  const double c0 = cpu();
  auto init = odometryInitialization(g);
  if (!init.ok()) return false;
  auto graph = buildPoseGraph(g, *init, BuildOptions{});
  if (!graph.ok()) return false;
  const BatchSummary s = solveBatch(*graph, BatchOptions{});
  if (!s.ok()) return false;
  r->wall_s = wall() - w0;
  r->cpu_s = cpu() - c0;
  r->sse = s.final_weighted_sse;
  r->peak_mb = peakMb();
  return true;
}

// fork() so that ru_maxrss is this data set's alone.
bool inChild(const GraphFile& g, bool incremental, Result* out) {
  int fd[2];
  if (pipe(fd) != 0) return false;
  const pid_t pid = fork();
  if (pid == 0) {
    close(fd[0]);
    Result r;
    const bool ok = incremental ? runIncremental(g, &r) : runBatch(g, &r);
    if (ok && write(fd[1], &r, sizeof r) != static_cast<ssize_t>(sizeof r)) _exit(2);
    _exit(ok ? 0 : 1);
  }
  close(fd[1]);
  const bool got = read(fd[0], out, sizeof *out) == static_cast<ssize_t>(sizeof *out);
  close(fd[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  return got && WIFEXITED(status) && WEXITSTATUS(status) == 0;
}

int table() {
  struct Case {
    const char* file;
    double isam_sse;
    double isam_incremental_s;
  };
  const Case cases[] = {{"manhattanOlson3500.txt", 6532.74, 2.4},
                        {"city10000.txt", 31931.4, 45.0},
                        {"sphere400.txt", 2312.06, 0.34},
                        {"sphere2500.txt", 14642.4, 21.0}};
  std::printf("%-22s | %-44s | %-22s | %s\n", "data set",
              "incremental: wall s (cpu s), step median/p99 ms", "batch: wall s (cpu s)",
              "peak MB inc/batch, SSE inc/batch (iSAM), wall ratio to iSAM inc");
  int failures = 0;
  for (const Case& c : cases) {
    const auto path = dataRoot() / "posegraph-isam" / c.file;
    auto g = readGraphFile(path);
    if (!g.ok()) {
      std::printf("%-22s | missing: %s\n", c.file, g.error().message.c_str());
      ++failures;
      continue;
    }
    Result inc;
    Result bat;
    if (!inChild(*g, true, &inc) || !inChild(*g, false, &bat)) {
      std::printf("%-22s | failed\n", c.file);
      ++failures;
      continue;
    }
    std::printf(
        "%-22s | %7.3f (%7.3f), %6.3f / %6.3f %14s | %7.3f (%7.3f) %6s | %5.1f / %5.1f, %.6g / "
        "%.6g (%.6g), %.2f\n",
        c.file, inc.wall_s, inc.cpu_s, inc.median_ms, inc.p99_ms, "", bat.wall_s, bat.cpu_s, "",
        inc.peak_mb, bat.peak_mb, inc.sse, bat.sse, c.isam_sse, inc.wall_s / c.isam_incremental_s);
    std::fflush(stdout);
  }
  return failures == 0 ? 0 : 1;
}

// Micro-benchmark: eliminating one new 3-row measurement into R of a long chain with a loop
// to the start (the worst single update shape: the path spans the whole chain).
void BM_AddRowsChainWithLoop(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  SquareRootFactor R;
  for (int p = 0; p < n; ++p) R.appendPosition(3);
  R.addRows(std::vector<int>{0}, Eigen::MatrixXd::Identity(3, 3), Eigen::VectorXd::Zero(3));
  Eigen::MatrixXd A = Eigen::MatrixXd::Random(3, 6);
  for (int p = 1; p < n; ++p) R.addRows(std::vector<int>{p - 1, p}, A, Eigen::VectorXd::Zero(3));
  for (auto _ : state) {
    SquareRootFactor copy = R;
    copy.addRows(std::vector<int>{0, n - 1}, A, Eigen::VectorXd::Ones(3));
    benchmark::DoNotOptimize(copy.row(n - 1).A.data());
  }
}
BENCHMARK(BM_AddRowsChainWithLoop)->Arg(100)->Arg(1000);

// Landmark problems (tools/sim/landmark_graphs.h): iSAM's cityTrees10000 and
// torus2000Points are not in the shared data, so generated stand-ins of the same kind,
// read through the iSAM reader once, outside the timed loop.
GraphFile landmarkProblem(bool spatial, int poses) {
  namespace sim = evermap::sim;
  const auto lg = spatial ? sim::torusPointsLike(sim::torusPointsOptions(poses))
                          : sim::cityTreesLike(sim::cityTreesOptions(poses));
  const auto path = std::filesystem::temp_directory_path() /
                    ("evermap_solver_bench_" + std::to_string(::getpid()) + ".txt");
  {
    std::ofstream out(path);
    out << lg.isam_text;
  }
  auto g = readGraphFile(path);
  std::filesystem::remove(path);
  if (!g.ok()) {
    std::fprintf(stderr, "%s\n", g.error().message.c_str());
    std::abort();
  }
  return *g;
}

void landmarkBatch(benchmark::State& state, bool spatial) {
  const GraphFile g = landmarkProblem(spatial, static_cast<int>(state.range(0)));
  BatchSummary last;
  for (auto _ : state) {
    auto init = odometryInitialization(g);
    auto graph = buildPoseGraph(g, *init, BuildOptions{});
    last = solveBatch(*graph, BatchOptions{});
    benchmark::DoNotOptimize(last.final_weighted_sse);
  }
  state.counters["observations"] = static_cast<double>(g.observations.size());
  state.counters["sse"] = last.final_weighted_sse;
}

// iSAM's run: update every step, batch step every 100, then batch iterations to convergence.
void landmarkIncremental(benchmark::State& state, bool spatial) {
  const GraphFile g = landmarkProblem(spatial, static_cast<int>(state.range(0)));
  BatchSummary last;
  for (auto _ : state) {
    OnlineRunner runner(g, OnlineOptions{});
    while (!runner.done()) {
      if (!runner.step().ok()) std::abort();
    }
    last = runner.solver().optimize(BatchOptions{});
    benchmark::DoNotOptimize(last.final_weighted_sse);
  }
  state.counters["observations"] = static_cast<double>(g.observations.size());
  state.counters["sse"] = last.final_weighted_sse;
}

void BM_LandmarksCityTreesBatch(benchmark::State& s) { landmarkBatch(s, false); }
void BM_LandmarksCityTreesIncremental(benchmark::State& s) { landmarkIncremental(s, false); }
void BM_LandmarksTorusPointsBatch(benchmark::State& s) { landmarkBatch(s, true); }
void BM_LandmarksTorusPointsIncremental(benchmark::State& s) { landmarkIncremental(s, true); }
// 2 000 poses, five repetitions, their aggregates only.
void landmarkRuns(benchmark::internal::Benchmark* b) {
  b->Arg(2000)->Unit(benchmark::kMillisecond)->Repetitions(5)->ReportAggregatesOnly(true);
}
BENCHMARK(BM_LandmarksCityTreesBatch)->Apply(landmarkRuns);
BENCHMARK(BM_LandmarksCityTreesIncremental)->Apply(landmarkRuns);
BENCHMARK(BM_LandmarksTorusPointsBatch)->Apply(landmarkRuns);
BENCHMARK(BM_LandmarksTorusPointsIncremental)->Apply(landmarkRuns);

}  // namespace

int main(int argc, char** argv) {
  tuneProcessForSolver();
  if (argc > 1 && std::string(argv[1]) == "--micro") {
    argv[1] = argv[0];
    --argc;
    ++argv;
    benchmark::Initialize(&argc, argv);
    benchmark::RunSpecifiedBenchmarks();
    return 0;
  }
  return table();
}
