#include "options.h"

#include <cmath>
#include <cstdlib>

namespace evermap::solver_tool {

std::string usage() {
  return R"(usage: evermap-solver [options] FILE
Optimises a pose graph (g2o 2-D/3-D, TORO 2-D, iSAM text) like iSAM's command line.
  --format auto|g2o|toro|isam   input format (default auto: by content)
  --objective native|sesync     native: the format's own residual (iSAM's or g2o's χ²);
                                sesync: SE-Sync's chordal cost f (reaches f*)
  --indefinite-information refuse|blocks|nearest
                                an information matrix that is not positive definite:
                                refuse (default; names the edge), blocks (translation and
                                rotation blocks without their coupling) or nearest (nearest
                                positive definite, eigenvalues >= 1e-6 lambda_max); ignored
                                by --objective sesync, which uses only the blocks
  --batch                       batch optimisation (default: incremental in file order)
  --method gn|lm|dogleg         Gauss-Newton (default), Levenberg-Marquardt (batch only),
                                Powell's dog leg (incremental: RISE)
  --init auto|odometry|chordal|file   batch initial values (auto: chordal for sesync,
                                else the file's vertices if present, else odometry)
  --robust none|pseudo-huber[:b]|cauchy[:b]|dcs[:phi]|gnc[:c2]   kernel on loop closures
                                (gnc: graduated non-convexity to truncated least squares,
                                c2 default chi2(dim, 0.99); batch only)
  --robust-odometry             apply the kernel to odometry edges too
  --batch-every N               incremental: batch relinearisation every N steps (100)
  --wildfire T                  incremental: partial back-substitution threshold (1e-9)
  --max-iterations N            budget of batch iterations (1000): batch mode, and the
                                final phase of an incremental run, which iterates batch
                                steps from the incremental estimate to convergence
                                (--max-iterations 1: iSAM's single final batch step)
  --tolerance R                 converged when a step lowers the cost by less than R·cost
                                (1e-10)
  --gradient-tolerance G        converged when max |gradient| <= G (1e-10)
  Exit status: 0 converged, 3 budget exhausted before convergence (the status line, printed
  last, says which test held or that none did), 1 failure, 2 bad arguments.
  --outliers N --seed S         add N false loop closures (seed S)
  --outlier-mode random|local|group   Vertigo's protocols: random pose pairs, pairs at most
                                20 poses apart, or groups of 10 mutually consistent false
                                closures between two stretches (default random)
  --ground-truth FILE           noise-free graph (iSAM groundtruth/ or g2o with vertices):
                                print the absolute trajectory error
  --output FILE.g2o             write the final estimate (and the edges) as g2o
  --stats FILE                  per-step statistics (incremental)
  --stats-chi2                  add the normalised χ² to each statistics line (O(m) a step)
  --marginals K1,K2,...         print the joint marginal covariance of these poses
  --verbose                     one line per batch iteration
)";
}

namespace {

Expected<double> number(const std::string& flag, const char* text) {
  char* end = nullptr;
  const double v = std::strtod(text, &end);
  if (!text[0] || *end != '\0' || !std::isfinite(v)) {
    return makeError(flag, ": '", text, "' is not a finite number");
  }
  return v;
}

}  // namespace

Expected<ToolOptions> parseArguments(int argc, char** argv) {
  ToolOptions o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> Expected<std::string> {
      if (i + 1 >= argc) return makeError(a, ": missing value");
      return std::string(argv[++i]);
    };
#define EVERMAP_VALUE(var) \
  auto var = value();      \
  if (!var.ok()) return var.error();
    if (a == "--help" || a == "-h") {
      return makeError("help");
    } else if (a == "--format") {
      EVERMAP_VALUE(v);
      auto f = solver::parseGraphFormat(*v);
      if (!f.ok()) return f.error();
      o.format = *f;
    } else if (a == "--objective") {
      EVERMAP_VALUE(v);
      auto f = solver::parseObjective(*v);
      if (!f.ok()) return f.error();
      o.objective = *f;
    } else if (a == "--indefinite-information") {
      EVERMAP_VALUE(v);
      auto r = solver::parseIndefiniteInformation(*v);
      if (!r.ok()) return r.error();
      o.indefinite = *r;
    } else if (a == "--outlier-mode") {
      EVERMAP_VALUE(v);
      auto m = solver::parseOutlierMode(*v);
      if (!m.ok()) return m.error();
      o.outlier_mode = *m;
    } else if (a == "--batch") {
      o.batch = true;
    } else if (a == "--method") {
      EVERMAP_VALUE(v);
      auto m = solver::parseMethod(*v);
      if (!m.ok()) return m.error();
      o.method = *m;
    } else if (a == "--init") {
      EVERMAP_VALUE(v);
      if (*v == "auto")
        o.init = Init::kAuto;
      else if (*v == "odometry")
        o.init = Init::kOdometry;
      else if (*v == "chordal")
        o.init = Init::kChordal;
      else if (*v == "file")
        o.init = Init::kFile;
      else
        return makeError("--init: '", *v, "': expected auto, odometry, chordal or file");
    } else if (a == "--robust") {
      EVERMAP_VALUE(v);
      auto k = solver::parseRobustKernel(*v);
      if (!k.ok()) return k.error();
      o.kernel = *k;
    } else if (a == "--robust-odometry") {
      o.robust_odometry = true;
    } else if (a == "--batch-every" || a == "--max-iterations" || a == "--outliers" ||
               a == "--seed") {
      EVERMAP_VALUE(v);
      auto n = number(a, v->c_str());
      if (!n.ok()) return n.error();
      // Stored in an int (a seed in an unsigned): larger values would not convert.
      const double most = a == "--seed" ? 4294967295.0 : 2147483647.0;
      if (*n < 0 || *n > most || *n != static_cast<long long>(*n)) {
        return makeError(a, ": expected an integer in [0, ", static_cast<long long>(most),
                         "], got '", *v, "'");
      }
      if (a == "--batch-every") o.batch_every = static_cast<int>(*n);
      if (a == "--max-iterations") o.max_iterations = static_cast<int>(*n);
      if (a == "--outliers") o.outliers = static_cast<int>(*n);
      if (a == "--seed") o.seed = static_cast<unsigned>(*n);
    } else if (a == "--wildfire" || a == "--tolerance" || a == "--gradient-tolerance") {
      EVERMAP_VALUE(v);
      auto n = number(a, v->c_str());
      if (!n.ok()) return n.error();
      if (*n < 0) return makeError(a, ": must be >= 0");
      (a == "--wildfire"    ? o.wildfire
       : a == "--tolerance" ? o.relative_tolerance
                            : o.gradient_tolerance) = *n;
    } else if (a == "--final-converge") {
      // Kept for old command lines: iterating to convergence is now the default.
    } else if (a == "--ground-truth") {
      EVERMAP_VALUE(v);
      o.ground_truth = *v;
    } else if (a == "--output") {
      EVERMAP_VALUE(v);
      o.output = *v;
    } else if (a == "--stats") {
      EVERMAP_VALUE(v);
      o.stats = *v;
    } else if (a == "--stats-chi2") {
      o.stats_chi2 = true;
    } else if (a == "--marginals") {
      EVERMAP_VALUE(v);
      o.marginals = *v;
    } else if (a == "--verbose") {
      o.verbose = true;
    } else if (!a.empty() && a[0] == '-') {
      return makeError("unknown option ", a);
    } else if (o.input.empty()) {
      o.input = a;
    } else {
      return makeError("more than one input file: ", o.input, " and ", a);
    }
#undef EVERMAP_VALUE
  }
  if (o.input.empty()) return makeError("no input file");
  if (o.max_iterations < 1) return makeError("--max-iterations: must be >= 1");
  if (!o.batch && o.kernel.type == solver::KernelType::kGncTls) {
    return makeError(
        "--robust gnc: graduated non-convexity re-solves the whole problem per "
        "stage and has no incremental mode; add --batch");
  }
  if (!o.batch && o.method == solver::Method::kLevenbergMarquardt) {
    return makeError("--method lm: Levenberg-Marquardt has no incremental mode; add --batch");
  }
  return o;
}

}  // namespace evermap::solver_tool
