// evermap-solver: batch or incremental (iSAM) optimisation of a pose-graph file.
// Parses options, runs core/solver, prints χ², weighted SSE and SE-Sync's f; see
// docs/solver.md.
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/common/atomic_write.h"
#include "core/common/percentile.h"
#include "core/solver/batch_solver.h"
#include "core/solver/graph_io.h"
#include "core/solver/gnc.h"
#include "core/solver/graph_problem.h"
#include "core/solver/marginals.h"
#include "core/solver/online_runner.h"
#include "core/solver/outliers.h"
#include "core/solver/process_tuning.h"
#include "core/solver/trajectory_error.h"
#include "options.h"

namespace {

using namespace evermap;
using namespace evermap::solver;
using evermap::solver_tool::Init;
using evermap::solver_tool::ToolOptions;

double cpuSeconds() {
  timespec t;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return t.tv_sec + 1e-9 * t.tv_nsec;
}

double wallSeconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

int fail(const std::string& message) {
  std::fprintf(stderr, "evermap-solver: %s\n", message.c_str());
  return 1;
}

Expected<Values> initialValues(const GraphFile& g, const ToolOptions& o) {
  Init init = o.init;
  if (init == Init::kAuto) {
    // SE-Sync's cost is minimised from the chordal relaxation (its own initialisation);
    // otherwise the file's vertices when it has them, else odometry chaining as iSAM.
    if (o.objective == Objective::kSeSync)
      init = Init::kChordal;
    else if (!g.vertices.empty())
      init = Init::kFile;
    else
      init = Init::kOdometry;
  }
  switch (init) {
    case Init::kFile:
      return fileInitialization(g);
    case Init::kChordal:
      return chordalInitialization(g);
    default:
      return odometryInitialization(g);
  }
}

// The costs of the final estimate. The anchor prior (factor 0, iSAM's 100·I on the first
// pose, which fixes the gauge) is not part of the file, so the χ², SSE and f lines sum the
// file's edges and landmark observations only and the anchor term is printed on its own
// line (f is SE-Sync's cost of the pose edges alone).
void printResult(const GraphFile& g, const PoseGraph& graph, const Values& estimate,
                 Objective objective) {
  Cost edges;
  Cost anchor;
  for (FactorId id = 0; id < graph.numFactorSlots(); ++id) {
    if (!graph.isActive(id)) continue;
    const Cost c = graph.cost(estimate, id);
    Cost& sum = id == 0 ? anchor : edges;
    sum.robust += c.robust;
    sum.weighted_sse += c.weighted_sse;
    sum.residual_dim += c.residual_dim;
  }
  const int64_t dof = edges.residual_dim - (estimate.totalDim() - estimate.at(0).dim());
  const char* what = g.observations.empty() ? "edges" : "edges and landmarks";
  std::printf("final chi2 of the %s (robust cost, sum rho)   %.10g\n", what, edges.robust);
  std::printf("weighted SSE of the %s (no 1/2)               %.10g\n", what, edges.weighted_sse);
  std::printf("normalized chi2                                  %.6g  (SSE / %lld dof)\n",
              dof > 0 ? edges.weighted_sse / dof : 0.0, static_cast<long long>(dof));
  std::printf("anchor prior on pose %lld (not in the file)        %.3g\n",
              static_cast<long long>(firstPoseId(g)), anchor.weighted_sse);
  std::printf("SE-Sync cost f of the edges                      %.10g%s\n", seSyncCost(g, estimate),
              objective == Objective::kSeSync ? "  (the minimised objective)"
                                              : "  (not the minimised objective: see --objective)");
}

BatchOptions batchOptions(const ToolOptions& o, Method method) {
  BatchOptions bo = o.final_batch;
  bo.method = method;
  return bo;
}

Status writeStats(const std::string& path, const std::vector<std::string>& lines) {
  std::ostringstream out;
  out << "# step wall_s cpu_s batch rows_modified rows_solved nnz_R poses factors"
      << " [normalized_chi2]\n";
  for (const auto& l : lines) out << l << '\n';
  return writeFileAtomically(path, out.str());  // whole or not at all
}

// One line on the graph read: format, size, what was skipped, indefinite information.
void printGraphSummary(const GraphFile& g, int indefinite) {
  std::printf("%s: %s, %d-D, %zu vertices, %zu edges", g.path.c_str(), graphFormatName(g.format),
              g.dimension, g.vertices.size(), g.edges.size());
  if (!g.observations.empty() || !g.landmarks.empty()) {
    std::printf(", %d landmarks, %zu landmark observations", g.numLandmarks(),
                g.observations.size());
  }
  if (g.skippedLines() > 0) {
    std::printf(", skipped:");
    for (const auto& [tag, n] : g.skipped_tags) std::printf(" %s x%d", tag.c_str(), n);
  }
  if (indefinite > 0) std::printf(", %d with an indefinite information matrix", indefinite);
  std::printf("\n");
}

// The graph file as it is solved: read, its information matrices resolved and checked, the
// false loop closures of --outliers added.
Expected<GraphFile> prepareGraph(const ToolOptions& o) {
  auto file = readGraphFile(o.input, o.format);
  if (!file.ok()) return file.error();
  GraphFile g = std::move(*file);
  int indefinite = 0;
  for (const GraphEdge& e : g.edges) indefinite += !e.positiveDefinite();
  printGraphSummary(g, indefinite);
  if (g.edges.empty()) return makeError(g.path, ": no edges read (wrong --format?)");
  if (indefinite > 0 && o.objective == Objective::kNative) {
    auto changed = resolveIndefiniteInformation(&g, o.indefinite);
    if (!changed.ok()) return changed.error();
    std::printf("%d information matrices replaced (--indefinite-information %s)\n", *changed,
                o.indefinite == IndefiniteInformation::kBlocks ? "blocks" : "nearest");
  }
  if (auto st = checkInformation(g, o.objective); !st.ok()) return st.error();
  if (o.outliers > 0) {
    OutlierOptions oo;
    oo.count = o.outliers;
    oo.seed = o.seed;
    oo.mode = o.outlier_mode;
    const size_t before = g.edges.size();
    g = addFalseLoopClosures(g, oo);
    std::printf("added %zu false loop closures, mode %s (seed %u)\n", g.edges.size() - before,
                outlierModeName(o.outlier_mode), o.seed);
  }
  return g;
}

// What a solve leaves: the estimate, the graph it is the estimate of, the final summary.
struct Solution {
  Values estimate;
  std::unique_ptr<PoseGraph> graph;
  BatchSummary summary;
};

// Batch: from the initial values of --init, GNC or the chosen method to convergence.
Expected<Solution> solveInBatch(const GraphFile& g, const ToolOptions& o,
                                const BuildOptions& build) {
  const double wall0 = wallSeconds();
  const double cpu0 = cpuSeconds();
  auto init = initialValues(g, o);
  if (!init.ok()) return init.error();
  auto built = buildPoseGraph(g, *init, build);
  if (!built.ok()) return built.error();
  Solution out;
  out.graph = std::make_unique<PoseGraph>(std::move(*built));
  PoseGraph& graph = *out.graph;
  std::printf("initial robust cost (edges + anchor) %.10g, SE-Sync f %.10g\n", graph.cost().robust,
              seSyncCost(g, graph.values()));
  BatchSummary s;
  if (o.kernel.type == KernelType::kGncTls) {
    GncOptions go;
    go.final_stage = batchOptions(o, o.method);
    const GncSummary gs = solveGnc(graph, go);
    std::printf("gnc: %d stages, final mu %.3g, %d of %d loop closures rejected (weight < 0.5)\n",
                gs.stages, gs.final_mu, gs.rejected, gs.candidates);
    s = gs.batch;
  } else {
    s = solveBatch(graph, batchOptions(o, o.method));
  }
  out.summary = s;
  const double wall = wallSeconds() - wall0;
  const double cpu = cpuSeconds() - cpu0;
  std::printf("batch %s: %s (%d iterations, %d factorizations, nnz(L) %lld)\n",
              methodName(o.method), s.message.c_str(), s.iterations, s.factorizations,
              static_cast<long long>(s.factor_nnz));
  std::printf("time: %.3f s wall, %.3f s cpu (initialisation included)\n", wall, cpu);
  if (!s.ok()) return makeError(s.message);
  out.estimate = graph.values();
  return out;
}

// One --stats line of the incremental run after a step.
std::string statsLine(const OnlineRunner& runner, const UpdateResult& r, double dw, double dc,
                      bool chi2) {
  const auto& s = runner.solver();
  std::ostringstream line;
  line << runner.nextStep() - 1 << ' ' << dw << ' ' << dc << ' ' << r.batch << ' '
       << r.rows_modified << ' ' << r.rows_solved << ' ' << s.nnz() << ' '
       << s.graph().values().size() << ' ' << s.graph().numActiveFactors();
  if (chi2) {
    const Cost cost = s.cost();
    const int64_t dof = cost.residual_dim - s.graph().values().totalDim();
    line << ' ' << (dof > 0 ? cost.weighted_sse / dof : 0.0);
  }
  return line.str();
}

// Incremental (iSAM) in file order, then batch iterations from its estimate to convergence.
Expected<Solution> solveIncrementally(const GraphFile& g, const ToolOptions& o,
                                      const BuildOptions& build) {
  const double wall0 = wallSeconds();
  const double cpu0 = cpuSeconds();
  OnlineOptions oo;
  oo.solver.method = o.method;
  oo.solver.batch_every = o.batch_every;
  oo.solver.wildfire_threshold = o.wildfire;
  oo.build = build;
  OnlineRunner runner(g, oo);
  std::vector<double> step_wall;
  std::vector<std::string> lines;
  int batches = 0;
  int rejected = 0;
  while (!runner.done()) {
    const double w = wallSeconds();
    const double c = cpuSeconds();
    auto r = runner.step();
    const double dw = wallSeconds() - w;
    const double dc = cpuSeconds() - c;
    if (!r.ok()) return r.error();
    step_wall.push_back(dw);
    batches += r->batch;
    rejected += !r->step_accepted;
    if (!o.stats.empty()) lines.push_back(statsLine(runner, *r, dw, dc, o.stats_chi2));
  }
  const double steps_wall = wallSeconds() - wall0;
  const double wf = wallSeconds();
  Solution out;
  // The final phase: batch iterations from the incremental estimate until a convergence
  // test holds or the budget runs out (--max-iterations 1 is iSAM's one final batch step).
  out.summary = runner.solver().optimize(
      batchOptions(o, o.method == Method::kDogLeg ? Method::kDogLeg : Method::kGaussNewton));
  if (!out.summary.ok()) return makeError(out.summary.message);
  const double final_wall = wallSeconds() - wf;
  const double wall = wallSeconds() - wall0;
  const double cpu = cpuSeconds() - cpu0;
  std::printf("incremental %s: %d steps, batch every %d (%d batch steps), wildfire %g%s\n",
              methodName(o.method), runner.numSteps(), o.batch_every, batches, o.wildfire,
              o.method == Method::kDogLeg
                  ? (", " + std::to_string(rejected) + " rejected steps").c_str()
                  : "");
  std::printf("time: %.3f s wall (steps %.3f s, final batch iterations %.3f s), %.3f s cpu\n", wall,
              steps_wall, final_wall, cpu);
  std::printf("final batch iterations: %s\n", out.summary.message.c_str());
  std::printf("per step: median %.3f ms, p99 %.3f ms, max %.3f ms; nnz(R) %lld\n",
              1e3 * evermap::percentile(step_wall, 0.5), 1e3 * evermap::percentile(step_wall, 0.99),
              1e3 * evermap::percentile(step_wall, 1.0),
              static_cast<long long>(runner.solver().nnz()));
  if (!o.stats.empty()) {
    if (auto st = writeStats(o.stats, lines); !st.ok()) return st.error();
  }
  out.estimate = runner.solver().estimate();
  out.graph = std::make_unique<PoseGraph>(runner.solver().graph());
  return out;
}

// --ground-truth: the absolute trajectory error of the estimate.
Status printTrajectoryError(const std::string& file, const Values& estimate) {
  auto gt = readGraphFile(file);
  if (!gt.ok()) return gt.error();
  auto truth = gt->vertices.empty() ? odometryInitialization(*gt) : fileInitialization(*gt);
  if (!truth.ok()) return truth.error();
  auto ate = absoluteTrajectoryError(estimate, *truth);
  if (!ate.ok()) return ate.error();
  std::printf("ATE vs %s: RMSE %.4f m, max %.4f m over %d poses\n", file.c_str(), ate->rmse_m,
              ate->max_m, ate->matched);
  return Ok{};
}

// --marginals: the joint marginal covariance of the listed poses at the estimate.
Status printMarginals(const std::string& list, const Solution& solution) {
  std::vector<Key> keys;
  std::stringstream ss(list);
  std::string item;
  while (std::getline(ss, item, ',')) keys.push_back(std::atoll(item.c_str()));
  PoseGraph at_estimate = *solution.graph;
  at_estimate.mutableValues() = solution.estimate;
  auto m = Marginals::compute(at_estimate);
  if (!m.ok()) return m.error();
  auto S = m->joint(keys);
  if (!S.ok()) return S.error();
  std::printf("joint marginal covariance of %s ((υ, ω) per pose, own frame):\n", list.c_str());
  for (int r = 0; r < S->rows(); ++r) {
    for (int c = 0; c < S->cols(); ++c) std::printf(" % .6e", (*S)(r, c));
    std::printf("\n");
  }
  return Ok{};
}

}  // namespace

int main(int argc, char** argv) {
  tuneProcessForSolver();
  ToolOptions o;
  if (const int code = solver_tool::parseArguments(argc, argv, &o); code >= 0) return code;
  auto g = prepareGraph(o);
  if (!g.ok()) return fail(g.error().message);
  BuildOptions build;
  build.objective = o.objective;
  build.kernel = o.kernel;
  build.robust_odometry = o.robust_odometry;
  auto solved = o.batch ? solveInBatch(*g, o, build) : solveIncrementally(*g, o, build);
  if (!solved.ok()) return fail(solved.error().message);
  const Solution& solution = *solved;
  rusage ru;
  getrusage(RUSAGE_SELF, &ru);
  std::printf("peak memory %.1f MB\n", ru.ru_maxrss / 1024.0);
  printResult(*g, *solution.graph, solution.estimate, o.objective);
  if (!o.ground_truth.empty()) {
    if (Status s = printTrajectoryError(o.ground_truth, solution.estimate); !s) {
      return fail(s.error().message);
    }
  }
  if (!o.marginals.empty()) {
    if (Status s = printMarginals(o.marginals, solution); !s) return fail(s.error().message);
  }
  if (!o.output.empty()) {
    if (auto st = writeG2o(o.output, *g, solution.estimate); !st.ok()) {
      return fail(st.error().message);
    }
    std::printf("wrote %s\n", o.output.c_str());
  }
  const BatchSummary& summary = solution.summary;
  // Printed last so that scripts and readers see it: converged, or the budget ran out.
  std::printf("status: %s after %d iterations (last relative decrease %.3g, max |gradient| %.3g)\n",
              summary.converged() ? terminationName(summary.termination)
                                  : "NOT CONVERGED, iteration budget exhausted",
              summary.iterations, summary.last_relative_decrease, summary.final_gradient_max);
  return summary.converged() ? 0 : 3;
}
