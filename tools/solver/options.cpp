#include "options.h"

#include <algorithm>
#include <cstdio>
#include <vector>

#include "core/common/command_line.h"
#include "core/common/option_fields.h"

namespace evermap::solver_tool {

namespace {

// The robust kernel as parseRobustKernel reads it back ("dcs:20"; "gnc" with its default).
std::string kernelText(const solver::RobustKernel& k) {
  static const char* const kNames[] = {"none", "pseudo-huber", "cauchy", "dcs", "gnc"};
  const std::string name = kNames[static_cast<int>(k.type)];
  if (!k.active() || k.parameter <= 0.0) return name;
  return name + ":" + option_text::ofDouble(k.parameter);
}

// The graph, its objective and the initial values.
void declareProblem(OptionList& o, ToolOptions* t) {
  using solver::GraphFormat;
  o.choice("format", &t->format,
           {{"auto", GraphFormat::kAuto},
            {"g2o", GraphFormat::kG2o},
            {"toro", GraphFormat::kToro},
            {"isam", GraphFormat::kIsam}},
           "input format (auto: by content)");
  o.choice("objective", &t->objective,
           {{"native", solver::Objective::kNative}, {"sesync", solver::Objective::kSeSync}},
           "native: the format's own residual (iSAM's or g2o's chi2); sesync: SE-Sync's chordal "
           "cost f (reaches f*)");
  using solver::IndefiniteInformation;
  o.choice("indefinite_information", &t->indefinite,
           {{"refuse", IndefiniteInformation::kRefuse},
            {"blocks", IndefiniteInformation::kBlocks},
            {"nearest", IndefiniteInformation::kNearest}},
           "an information matrix that is not positive definite: refuse (names the edge), blocks "
           "(translation and rotation blocks without their coupling) or nearest (nearest positive "
           "definite, eigenvalues >= 1e-6 lambda_max); ignored by objective sesync");
  o.choice("init", &t->init,
           {{"auto", Init::kAuto},
            {"odometry", Init::kOdometry},
            {"chordal", Init::kChordal},
            {"file", Init::kFile}},
           "batch initial values (auto: chordal for sesync, else the file's vertices if present, "
           "else odometry)");
  o.add("outliers", &t->outliers, "", "add this many false loop closures").in(0, 2147483647);
  o.add("seed", &t->seed, "", "seed of the false loop closures").any();
  using solver::OutlierMode;
  o.choice("outlier_mode", &t->outlier_mode,
           {{"random", OutlierMode::kRandom},
            {"local", OutlierMode::kLocal},
            {"group", OutlierMode::kGroup}},
           "Vertigo's protocols: random pose pairs, pairs at most 20 poses apart, or groups of 10 "
           "mutually consistent false closures between two stretches");
}

// How it is solved.
void declareSolver(OptionList& o, ToolOptions* t) {
  o.add("batch", &t->batch, "batch optimisation (else incremental in file order)");
  using solver::Method;
  o.choice("method", &t->method,
           {{"gn", Method::kGaussNewton},
            {"lm", Method::kLevenbergMarquardt},
            {"dogleg", Method::kDogLeg}},
           "Gauss-Newton, Levenberg-Marquardt (batch only), Powell's dog leg (incremental: RISE)");
  o.custom<solver::RobustKernel>(
      "robust", &t->kernel, solver::parseRobustKernel, kernelText,
      "none | pseudo-huber[:b] | cauchy[:b] | dcs[:phi] | gnc[:c2]",
      "kernel on loop closures (gnc: graduated non-convexity to truncated least squares, c2 "
      "default chi2(dim, 0.99); batch only)");
  o.add("robust_odometry", &t->robust_odometry, "apply the kernel to odometry edges too");
  o.add("batch_every", &t->batch_every, "", "incremental: batch relinearisation every N steps")
      .in(0, 2147483647);
  o.add("wildfire", &t->wildfire, "", "incremental: partial back-substitution threshold").min(0);
  o.add("max_iterations", &t->final_batch.max_iterations, "",
        "budget of batch iterations: batch mode, and the final phase of an incremental run (1: "
        "iSAM's single final batch step)")
      .in(1, 2147483647);
  o.add("tolerance", &t->final_batch.relative_cost_tolerance, "",
        "converged when a step lowers the cost by less than this times the cost")
      .min(0);
  o.add("gradient_tolerance", &t->final_batch.gradient_tolerance, "",
        "converged when max |gradient| <= this")
      .min(0);
  o.add("stats_chi2", &t->stats_chi2,
        "add the normalised chi2 to each statistics line (O(m) a step)");
  o.add("verbose", &t->final_batch.verbose, "one line per batch iteration");
}

// The files it reads and writes besides the graph.
void declareFiles(CommandLine* cli, ToolOptions* o) {
  cli->value("--ground-truth", &o->ground_truth, "FILE",
             "noise-free graph (iSAM groundtruth/ or g2o with vertices): print the absolute "
             "trajectory error");
  cli->value("--output", &o->output, "FILE.g2o", "write the final estimate (and the edges) as g2o");
  cli->value("--stats", &o->stats, "FILE", "per-step statistics (incremental)");
  cli->value("--marginals", &o->marginals, "K1,K2,...",
             "print the joint marginal covariance of these poses");
  static bool final_converge = false;  // kept for old command lines: now the default
  cli->flag("--final-converge", &final_converge,
            "(no effect: iterating to convergence is the default)");
}

// Every setting keeps its flag: --batch-every N is --set batch_every=N.
void declareAliases(CommandLine* cli) {
  for (const char* key : {"format", "objective", "indefinite_information", "init", "outliers",
                          "seed", "outlier_mode", "method", "robust", "batch_every", "wildfire",
                          "max_iterations", "tolerance", "gradient_tolerance"}) {
    std::string flag = std::string("--") + key;
    std::replace(flag.begin(), flag.end(), '_', '-');
    cli->alias(flag, key, "VALUE");
  }
  for (const char* key : {"batch", "robust_odometry", "stats_chi2", "verbose"}) {
    std::string flag = std::string("--") + key;
    std::replace(flag.begin(), flag.end(), '_', '-');
    cli->alias(flag, key, "");
  }
}

// What the options leave to check together.
Status checkCombination(const std::vector<std::string>& inputs, const ToolOptions& o) {
  if (inputs.empty()) return makeError("no input file");
  if (inputs.size() > 1)
    return makeError("more than one input file: ", inputs[0], " and ", inputs[1]);
  if (!o.batch && o.kernel.type == solver::KernelType::kGncTls) {
    return makeError(
        "--robust gnc: graduated non-convexity re-solves the whole problem per "
        "stage and has no incremental mode; add --batch");
  }
  if (!o.batch && o.method == solver::Method::kLevenbergMarquardt) {
    return makeError("--method lm: Levenberg-Marquardt has no incremental mode; add --batch");
  }
  return Ok{};
}

}  // namespace

void ToolOptions::declareOptions(OptionList& o) {
  declareProblem(o, this);
  declareSolver(o, this);
}

int parseArguments(int argc, char** argv, ToolOptions* o) {
  CommandLine cli(
      "evermap-solver",
      "Optimises a pose graph (g2o 2-D/3-D, TORO 2-D, iSAM text) like iSAM's command line.\n"
      "Exit status: 0 converged, 3 budget exhausted before convergence (the status line, printed\n"
      "last, says which test held or that none did), 1 failure, 2 bad arguments.");
  std::vector<std::string> inputs;
  cli.positional(&inputs, "FILE", "the pose graph");
  declareFiles(&cli, o);
  cli.options(o);
  declareAliases(&cli);
  if (const int code = cli.parseOrExit(argc, argv); code >= 0) return code;
  if (Status s = checkCombination(inputs, *o); !s) {
    std::fprintf(stderr, "evermap-solver: %s\n%s", s.error().message.c_str(), cli.usage().c_str());
    return 2;
  }
  o->input = inputs[0];
  return -1;
}

}  // namespace evermap::solver_tool
