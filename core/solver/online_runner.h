#pragma once
// Feeds a pose-graph file to the incremental solver in file order, one step per new pose,
// as iSAM's command line does: a step adds the new pose (initialised by composing the
// current estimate of its neighbour with the measurement — odometry chaining) and every
// edge up to the next new pose. Landmark observations join the step in which their line
// comes (the observing pose must exist by then); a landmark first seen is added in that step,
// initialised as the observing pose's current estimate ⊕ the measurement (iSAM's rule).
// Timing is the caller's business (no clock in here).

#include <vector>

#include "core/common/expected.h"
#include "core/solver/graph_problem.h"
#include "core/solver/incremental_solver.h"

namespace evermap::solver {

struct OnlineOptions {
  IncrementalOptions solver;
  BuildOptions build;  // objective, robust kernel, anchor
};

class OnlineRunner {
 public:
  OnlineRunner(const GraphFile& graph, const OnlineOptions& options);

  int numSteps() const { return static_cast<int>(steps_.size()); }
  int nextStep() const { return next_; }
  bool done() const { return next_ >= numSteps(); }
  // Runs the next step.
  Expected<UpdateResult> step();
  // iSAM's end of an incremental run: one more batch step (relinearise and refactor).
  Status finish() { return solver_.batchStep(); }

  IncrementalSolver& solver() { return solver_; }
  const IncrementalSolver& solver() const { return solver_; }

 private:
  struct Step {
    Key new_pose = 0;
    int init_edge = -1;  // edge that initialises the new pose (-1: the first pose)
    std::vector<int> edges;
    std::vector<int> observations;   // indices into graph.observations
    std::vector<int> new_landmarks;  // observations that introduce their landmark
  };
  const GraphFile& graph_;
  OnlineOptions options_;
  IncrementalSolver solver_;
  std::vector<Step> steps_;
  int next_ = 0;
};

}  // namespace evermap::solver
