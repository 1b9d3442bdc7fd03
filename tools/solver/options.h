#pragma once
// Command-line options of evermap-solver (--help, docs/solver.md).

#include <string>

#include "core/common/expected.h"
#include "core/solver/batch_solver.h"
#include "core/solver/graph_io.h"
#include "core/solver/graph_problem.h"
#include "core/solver/outliers.h"
#include "core/solver/robust_kernel.h"

namespace evermap {
class OptionList;
}

namespace evermap::solver_tool {

enum class Init { kAuto, kOdometry, kChordal, kFile };

struct ToolOptions {
  std::string input;
  solver::GraphFormat format = solver::GraphFormat::kAuto;
  solver::Objective objective = solver::Objective::kNative;
  // Edges whose information matrix is not positive definite (native objective only).
  solver::IndefiniteInformation indefinite = solver::IndefiniteInformation::kRefuse;
  bool batch = false;  // default: incremental in file order, like iSAM
  solver::Method method = solver::Method::kGaussNewton;
  Init init = Init::kAuto;
  solver::RobustKernel kernel;
  bool robust_odometry = false;
  int batch_every = 100;
  double wildfire = 1e-9;
  // The batch iterations (batch mode, and the final phase of an incremental run): their
  // budget, tolerances and verbosity; the method is `method`'s.
  solver::BatchOptions final_batch;
  int outliers = 0;
  solver::OutlierMode outlier_mode = solver::OutlierMode::kRandom;
  unsigned seed = 1;
  std::string ground_truth;
  std::string output;  // g2o
  std::string stats;   // per-step statistics
  bool stats_chi2 = false;
  std::string marginals;  // comma-separated keys

  // The settings (not the files): key, default, unit, allowed values, doc (options.cpp).
  void declareOptions(OptionList& o);
};

// The command line into `*o`: -1 to run, else the exit status (0 after --help, 2 after a bad
// command line; the error, naming the option, and the usage already printed).
int parseArguments(int argc, char** argv, ToolOptions* o);

}  // namespace evermap::solver_tool
