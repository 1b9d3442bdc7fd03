#pragma once
// Synthetic trajectories for the tools/eval tests: a 3-D curve with turning orientations, so
// that every alignment and metric has something non-degenerate to find.

#include <cmath>
#include <string>

#include "tools/eval/trajectory.h"

namespace evermap::eval::testing {

// n poses at 10 Hz along a rising, wobbling circle of radius 5 m; stamps start at t0_ns.
inline Trajectory syntheticTrajectory(size_t n, int64_t t0_ns = 1000000000LL,
                                      const std::string& source = "synthetic") {
  Trajectory t{source, {}};
  for (size_t k = 0; k < n; ++k) {
    const double a = 0.05 * static_cast<double>(k);
    const core::Vec3 p(5.0 * std::cos(a), 5.0 * std::sin(a), 0.3 * a + 0.5 * std::sin(3.0 * a));
    const core::SO3d R = core::SO3d::fromRollPitchYaw(0.1 * std::sin(a), 0.05 * std::cos(2 * a),
                                                      a + 1.5707963267948966);
    t.poses.push_back({t0_ns + static_cast<int64_t>(k) * 100000000LL, core::SE3d(R, p)});
  }
  return t;
}

}  // namespace evermap::eval::testing
