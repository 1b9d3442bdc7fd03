#include "options.h"

#include <cstdio>
#include <vector>

#include "core/common/command_line.h"

namespace evermap::solver_tool {

namespace {

// An option whose text is parsed by `parse` (one of core/solver's parseX) into `*out`.
template <typename T, typename Parse>
std::function<Status(const std::string&)> parsedInto(T* out, Parse parse) {
  return [out, parse](const std::string& v) -> Status {
    auto r = parse(v);
    if (!r.ok()) return r.error();
    *out = *r;
    return Ok{};
  };
}

Expected<Init> parseInit(const std::string& v) {
  if (v == "auto") return Init::kAuto;
  if (v == "odometry") return Init::kOdometry;
  if (v == "chordal") return Init::kChordal;
  if (v == "file") return Init::kFile;
  return makeError("'", v, "': expected auto, odometry, chordal or file");
}

// The graph, its objective and the initial values.
void declareProblem(CommandLine* cli, ToolOptions* o) {
  cli->value("--format", parsedInto(&o->format, solver::parseGraphFormat), "auto|g2o|toro|isam",
             "input format (default auto: by content)");
  cli->value("--objective", parsedInto(&o->objective, solver::parseObjective), "native|sesync",
             "native: the format's own residual (iSAM's or g2o's chi2); sesync: SE-Sync's chordal "
             "cost f (reaches f*)");
  cli->value("--indefinite-information",
             parsedInto(&o->indefinite, solver::parseIndefiniteInformation),
             "refuse|blocks|nearest",
             "an information matrix that is not positive definite: refuse (default; names the "
             "edge), blocks (translation and rotation blocks without their coupling) or nearest "
             "(nearest positive definite, eigenvalues >= 1e-6 lambda_max); ignored by --objective "
             "sesync, which uses only the blocks");
  cli->value("--init", parsedInto(&o->init, parseInit), "auto|odometry|chordal|file",
             "batch initial values (auto: chordal for sesync, else the file's vertices if present, "
             "else odometry)");
  cli->value("--outliers", &o->outliers, "N", "add N false loop closures (seed --seed)")
      .min(0)
      .max(2147483647);
  cli->value("--seed", &o->seed, "S", "seed of --outliers (1)").any();
  cli->value("--outlier-mode", parsedInto(&o->outlier_mode, solver::parseOutlierMode),
             "random|local|group",
             "Vertigo's protocols: random pose pairs, pairs at most 20 poses apart, or groups of "
             "10 mutually consistent false closures between two stretches (default random)");
}

// How it is solved.
void declareSolver(CommandLine* cli, ToolOptions* o) {
  cli->flag("--batch", &o->batch, "batch optimisation (default: incremental in file order)");
  cli->value("--method", parsedInto(&o->method, solver::parseMethod), "gn|lm|dogleg",
             "Gauss-Newton (default), Levenberg-Marquardt (batch only), Powell's dog leg "
             "(incremental: RISE)");
  cli->value("--robust", parsedInto(&o->kernel, solver::parseRobustKernel),
             "none|pseudo-huber[:b]|cauchy[:b]|dcs[:phi]|gnc[:c2]",
             "kernel on loop closures (gnc: graduated non-convexity to truncated least squares, "
             "c2 default chi2(dim, 0.99); batch only)");
  cli->flag("--robust-odometry", &o->robust_odometry, "apply the kernel to odometry edges too");
  cli->value("--batch-every", &o->batch_every, "N",
             "incremental: batch relinearisation every N steps (100)")
      .min(0);
  cli->value("--wildfire", &o->wildfire, "T",
             "incremental: partial back-substitution threshold (1e-9)")
      .min(0);
  cli->value("--max-iterations", &o->max_iterations, "N",
             "budget of batch iterations (1000): batch mode, and the final phase of an incremental "
             "run, which iterates batch steps from the incremental estimate to convergence "
             "(--max-iterations 1: iSAM's single final batch step)")
      .min(1);
  cli->value("--tolerance", &o->relative_tolerance, "R",
             "converged when a step lowers the cost by less than R*cost (1e-10)")
      .min(0);
  cli->value("--gradient-tolerance", &o->gradient_tolerance, "G",
             "converged when max |gradient| <= G (1e-10)")
      .min(0);
  static bool final_converge = false;  // kept for old command lines: now the default
  cli->flag("--final-converge", &final_converge,
            "(no effect: iterating to convergence is the "
            "default)");
  cli->flag("--verbose", &o->verbose, "one line per batch iteration");
}

// What it writes and prints besides the costs.
void declareOutputs(CommandLine* cli, ToolOptions* o) {
  cli->value("--ground-truth", &o->ground_truth, "FILE",
             "noise-free graph (iSAM groundtruth/ or g2o with vertices): print the absolute "
             "trajectory error");
  cli->value("--output", &o->output, "FILE.g2o", "write the final estimate (and the edges) as g2o");
  cli->value("--stats", &o->stats, "FILE", "per-step statistics (incremental)");
  cli->flag("--stats-chi2", &o->stats_chi2,
            "add the normalised chi2 to each statistics line (O(m) a step)");
  cli->value("--marginals", &o->marginals, "K1,K2,...",
             "print the joint marginal covariance of these poses");
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

int parseArguments(int argc, char** argv, ToolOptions* o) {
  CommandLine cli(
      "evermap-solver",
      "Optimises a pose graph (g2o 2-D/3-D, TORO 2-D, iSAM text) like iSAM's command line.\n"
      "Exit status: 0 converged, 3 budget exhausted before convergence (the status line, printed\n"
      "last, says which test held or that none did), 1 failure, 2 bad arguments.");
  std::vector<std::string> inputs;
  cli.positional(&inputs, "FILE", "the pose graph");
  declareProblem(&cli, o);
  declareSolver(&cli, o);
  declareOutputs(&cli, o);
  if (const int code = cli.parseOrExit(argc, argv); code >= 0) return code;
  if (Status s = checkCombination(inputs, *o); !s) {
    std::fprintf(stderr, "evermap-solver: %s\n%s", s.error().message.c_str(), cli.usage().c_str());
    return 2;
  }
  o->input = inputs[0];
  return -1;
}

}  // namespace evermap::solver_tool
