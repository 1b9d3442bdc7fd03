#pragma once
// A localization run against the truth (docs/localization.md): the stored map put in the
// truth's frame by its nodes, each localized pose's error, and the figures over the localized
// ones. Shared by evermap-slam-run --localize (offline) and evermap-pipeline-eval
// --localization-log (a run recorded live).

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "core/common/expected.h"
#include "core/geometry/se3.h"
#include "core/geometry/umeyama.h"

namespace evermap::eval {

// One pose the localizer gave (a VO frame's): world_T_body in the map's frame, whether it was
// placed on the map and localized then, and the stored node it was tracked against.
struct LocalizedPose {
  int64_t utime = 0;
  bool placed = false, localized = false;
  core::SE3d world_T_body;
  int64_t node = -1;                    // -1: none (not placed)
  double error_m = -1, error_deg = -1;  // against the truth; -1: none within 25 ms
};

// A stored node's pose in the map and the truth's pose of the robot at its keyframe.
struct StoredNodeTruth {
  core::SE3d world_T_node, truth_T_node;
};

struct LocalizationAccuracy {
  int64_t poses = 0;              // all given
  int64_t localized = 0;          // ... with localized = true
  double first_localized_s = -1;  // from the first pose to the first localized one
  // Localized poses with truth only; -1 when there are none.
  int64_t poses_with_truth = 0;
  double ate_rmse_m = -1, ate_p95_m = -1, ate_max_m = -1, rot_rmse_deg = -1;
  int64_t false_poses = -1;       // error beyond false_m or false_deg
  int64_t false_placements = -1;  // placements whose first localized pose is such an error
  double false_m = 0.5, false_deg = 5.0;
  // The same against the node each pose is tracked against (its pose relative to that node's,
  // and the truth's relative to the truth at the node's keyframe): the localizer's error
  // without the stored map's own. -1 when no localized pose names a node with truth.
  int64_t node_poses = 0;
  double node_rmse_m = -1, node_rot_rmse_deg = -1;
  int64_t node_false_poses = -1, node_false_placements = -1;
};

// The map in the truth's frame from its nodes' estimated and true poses (paired by index): the
// least-squares rigid fit of their positions from three nodes not on one line; else (one or two
// nodes: a camera turning in place; nodes along one corridor) the first node's whole pose. Errors:
// no node, sizes differ, a degenerate fit.
Expected<core::Similarity> mapToTruth(const std::vector<core::SE3d>& map_nodes,
                                      const std::vector<core::SE3d>& true_nodes);

// The counts of LocalizationAccuracy: poses, localized, first_localized_s.
void countLocalized(const std::vector<LocalizedPose>& poses, LocalizationAccuracy* a);

// Fills each pose's error (the truth at its stamp, within 25 ms, placed poses only) and
// returns the figures, the counts among them; `poses` in time order. `nodes` (by node id; may
// be empty) gives the figures against the node tracked.
LocalizationAccuracy evaluateLocalization(std::vector<LocalizedPose>& poses,
                                          const core::Similarity& truth_S_map,
                                          const std::map<int64_t, core::SE3d>& truth,
                                          const std::map<int64_t, StoredNodeTruth>& nodes,
                                          double false_m, double false_deg);

// "truth frames_localized N ate_rmse_m ... false_frames F false_placements P (beyond ...)" and,
// when there are node figures, "truth_against_node frames N ate_rmse_m ... false_placements P":
// the lines localize-summary.txt and evermap-pipeline-eval print.
std::string truthLine(const LocalizationAccuracy& a);

}  // namespace evermap::eval
