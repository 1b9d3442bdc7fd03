#pragma once
// Synthetic landmark SLAM problems in iSAM's text format, with their noise-free truth: the
// stand-ins for iSAM's cityTrees10000 (2-D: odometry on a Manhattan grid, point landmarks
// — "trees" — seen within a range) and torus2000Points (3-D: a path wound around a torus,
// points near its surface), which are not in the shared data (see docs/solver.md).
//
// Truth pose i has id i, pose 0 is the origin (iSAM's anchor), landmark j has id j. Odometry
// measures i_T_{i+1} of the truth, perturbed by a tangent-space draw
// (2-D: (x, y, θ) added; 3-D: z = i_T_{i+1} · exp(υ, ω)); a landmark is measured in the pose's
// frame, R_iᵀ(l − t_i), plus an isotropic normal draw. The square-root information written
// on each line is the inverse of those sigmas, so the weighted SSE of the truth is a χ²
// sample with as many degrees of freedom as residual rows. All sigmas 0 gives exact data
// (information from `nominal_sigma` then).

#include <cstdint>
#include <string>
#include <vector>

#include "core/geometry/se2.h"
#include "core/geometry/se3.h"

namespace evermap::sim {

struct LandmarkGraphOptions {
  int poses = 1000;
  int landmarks = 100;                // placed; only those seen are written
  double sensor_range_m = 4.0;        // a landmark is seen within this distance of a pose
  int max_observations_per_pose = 2;  // the nearest ones
  double odometry_sigma_m = 0.05;
  double odometry_sigma_rad = 0.01;
  double point_sigma_m = 0.1;
  double nominal_sigma = 0.05;  // information for the zero-noise case
  uint64_t seed = 1;
};

struct LandmarkGraph {
  int dimension = 2;
  std::string isam_text;           // EDGE2 + LANDMARK lines, or EDGE3 + POINT3 lines
  std::vector<core::SE2d> poses2;  // truth, dimension 2
  std::vector<core::SE3d> poses3;  // truth, dimension 3
  std::vector<core::Vec3> points;  // truth by landmark id (z = 0 in 2-D)
  int observations = 0;
  int observed_landmarks = 0;
};

// The settings of the bench, the tests and docs/solver.md: cityTrees-like with poses / 10
// landmarks; torusPoints-like with poses / 5 landmarks and odometry σ 0.02 m / 0.005 rad.
LandmarkGraphOptions cityTreesOptions(int poses, uint64_t seed = 1);
LandmarkGraphOptions torusPointsOptions(int poses, uint64_t seed = 1);

// 2-D: a walk on a 1 m grid (turns of ±90° at random, kept inside a square sized to the
// number of poses), landmarks uniform over the square.
LandmarkGraph cityTreesLike(const LandmarkGraphOptions& options);
// 3-D: a path winding around a torus (major radius 10 m, minor 3 m, x along the path, z
// along the surface normal), landmarks 0.5-2 m off the surface.
LandmarkGraph torusPointsLike(const LandmarkGraphOptions& options);

}  // namespace evermap::sim
