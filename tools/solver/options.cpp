#include "options.h"

#include <cstdlib>

namespace evermap::solver_tool {

std::string usage() {
  return R"(usage: evermap-solver [options] FILE
Optimises a pose graph (g2o 2-D/3-D, TORO 2-D, iSAM text) like iSAM's command line.
  --format auto|g2o|toro|isam   input format (default auto: by content)
  --objective native|sesync     native: the format's own residual (iSAM's or g2o's χ²);
                                sesync: SE-Sync's chordal cost f (reaches f*)
  --batch                       batch optimisation (default: incremental in file order)
  --method gn|lm|dogleg         Gauss-Newton (default), Levenberg-Marquardt (batch only),
                                Powell's dog leg (incremental: RISE)
  --init auto|odometry|chordal|file   batch initial values (auto: chordal for sesync,
                                else the file's vertices if present, else odometry)
  --robust none|pseudo-huber[:b]|cauchy[:b]|dcs[:phi]   kernel on loop closures
  --robust-odometry             apply the kernel to odometry edges too
  --batch-every N               incremental: batch relinearisation every N steps (100)
  --wildfire T                  incremental: partial back-substitution threshold (1e-9)
  --final-converge              incremental: finish with batch iterations to convergence
                                (default: one final batch step, as iSAM)
  --max-iterations N            batch iterations (100)
  --tolerance R                 batch: stop when the cost drops by less than R·cost (1e-10)
  --outliers N --seed S         add N random false loop closures (seed S)
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
  if (!text[0] || *end != '\0') return makeError(flag, ": '", text, "' is not a number");
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
#define EVERMAP_VALUE(var)                 \
  auto var = value();                      \
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
    } else if (a == "--batch") {
      o.batch = true;
    } else if (a == "--method") {
      EVERMAP_VALUE(v);
      auto m = solver::parseMethod(*v);
      if (!m.ok()) return m.error();
      o.method = *m;
    } else if (a == "--init") {
      EVERMAP_VALUE(v);
      if (*v == "auto") o.init = Init::kAuto;
      else if (*v == "odometry") o.init = Init::kOdometry;
      else if (*v == "chordal") o.init = Init::kChordal;
      else if (*v == "file") o.init = Init::kFile;
      else return makeError("--init: '", *v, "': expected auto, odometry, chordal or file");
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
      if (*n < 0 || *n != static_cast<long long>(*n)) {
        return makeError(a, ": expected a non-negative integer, got '", *v, "'");
      }
      if (a == "--batch-every") o.batch_every = static_cast<int>(*n);
      if (a == "--max-iterations") o.max_iterations = static_cast<int>(*n);
      if (a == "--outliers") o.outliers = static_cast<int>(*n);
      if (a == "--seed") o.seed = static_cast<unsigned>(*n);
    } else if (a == "--wildfire" || a == "--tolerance") {
      EVERMAP_VALUE(v);
      auto n = number(a, v->c_str());
      if (!n.ok()) return n.error();
      if (*n < 0) return makeError(a, ": must be >= 0");
      (a == "--wildfire" ? o.wildfire : o.relative_tolerance) = *n;
    } else if (a == "--final-converge") {
      o.final_converge = true;
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
  if (!o.batch && o.method == solver::Method::kLevenbergMarquardt) {
    return makeError("--method lm: Levenberg-Marquardt has no incremental mode; add --batch");
  }
  return o;
}

}  // namespace evermap::solver_tool
