#pragma once
// Synthetic false loop closures for robustness experiments, the protocols of Sünderhauf &
// Protzel's Vertigo suite (generateDataset.py; "Switchable constraints for robust pose graph
// SLAM", IROS 2012, and "Switchable constraints vs. max-mixture models vs. RRR", 2013):
//
//   random — a pair of poses drawn uniformly over the whole trajectory;
//   local  — the second pose within `local_window` poses after the first (a place
//            recogniser confusing a place with one seen moments before);
//   group  — `group_size` closures between two stretches of the trajectory, a_k = a + k and
//            b_k = b + k, that agree with each other: all say that pose b sits at a false
//            relative pose T from pose a, each measured through the file's own odometry
//            (z_k = (a_T_ak)⁻¹ T b_T_bk with a_T_ak, b_T_bk chained odometry measurements).
//            This is perceptual aliasing: one wrong place match seen over several frames,
//            mutually consistent, so a kernel cannot reject the group by its disagreement.
// Random and local closures carry a measurement drawn as Vertigo does (translation N(0, 3 m)
// per axis, rotation N(0, 10°) per axis); a group's T is drawn the same way. Each closure
// gets the information matrix of a real loop closure of the file drawn at random, and is
// inserted into the edge stream right after both of its poses exist (so an incremental run
// sees it online). Synthetic edges have line 0.

#include <cstdint>
#include <string>

#include "core/common/expected.h"
#include "core/solver/graph_io.h"

namespace evermap::solver {

enum class OutlierMode { kRandom, kLocal, kGroup };
Expected<OutlierMode> parseOutlierMode(const std::string& text);  // random, local, group
const char* outlierModeName(OutlierMode mode);

struct OutlierOptions {
  int count = 0;  // false closures in all (a last group may be shorter)
  uint32_t seed = 1;
  OutlierMode mode = OutlierMode::kRandom;
  // Measurement noise of a false closure (or of a group's T): per axis, metres / radians.
  double translation_sigma_m = 3.0;
  double rotation_sigma_rad = 10.0 * 3.14159265358979323846 / 180.0;
  // local: the second pose is 2..local_window poses after the first (Vertigo: 20).
  int local_window = 20;
  // group: closures per group (Vertigo draws up to its --groupsize; we fix it).
  int group_size = 10;
};

// A copy of `graph` with `count` false loop closures inserted; their `line` is 0.
// Group mode needs odometry edges (ids i, i+1) along both stretches; it draws again where
// they are missing.
GraphFile addFalseLoopClosures(const GraphFile& graph, const OutlierOptions& options);
bool isSyntheticOutlier(const GraphEdge& edge);

}  // namespace evermap::solver
