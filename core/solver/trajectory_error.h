#pragma once
// Absolute trajectory error of an estimate against ground truth: the rigid transform that
// best aligns the estimated positions to the true ones (Umeyama 1991, without scale), then
// the RMS of the remaining position differences. Used by the solver tool and its tests;
// the project's evaluation tools (DESIGN.md section 10) report the same figure.

#include "core/common/expected.h"
#include "core/solver/values.h"

namespace evermap::solver {

struct TrajectoryError {
  double rmse_m = 0.0;
  double max_m = 0.0;
  int matched = 0;  // poses present in both
};

// Over the keys present in both; errors when fewer than 3 match.
Expected<TrajectoryError> absoluteTrajectoryError(const Values& estimate, const Values& truth);

}  // namespace evermap::solver
