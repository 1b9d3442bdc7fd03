#pragma once
// End-of-run evaluation of a map against the ground truth of a simulated run (DESIGN.md
// section 10): the map comes from the last MAP_GRAPH of a recorded LCM log (what the live
// pipeline published) or from a map store (what the offline runner or mapper-proc wrote); the
// truth from the run folder evermap-sim-measure --out wrote (session-NN.tum, run.sim.txt).
//
// Node ATE: each node's world_T_body against the true body pose at its keyframe's time,
// SE(3)-aligned (Umeyama; the map's origin is its first node, the truth's the building's).
// Floors: each node's floor label against the floor whose height is nearest the true height,
// and the map's floor table against the building's. POSE ATE (log only): the live estimates
// the mapper published, against the truth at their times, SE(3)-aligned as one trajectory.

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include <evermap/map_graph_t.hpp>
#include <evermap/mapper_stats_t.hpp>
#include <evermap/pose_t.hpp>

#include "core/common/expected.h"
#include "core/geometry/se3.h"
#include "tools/lcmlog/log_reader.h"

namespace evermap::mapper {

struct EvalNode {
  int64_t id = 0;
  int64_t keyframe_utime = 0;
  core::SE3d world_T_body;
  int floor = 0;
  int session = 0;
};

// A node pair holding a loop closure: the merged relative pose (MAP_GRAPH edges only).
struct EvalLoop {
  int64_t from = 0, to = 0;
  core::SE3d from_T_to;
};

// What is evaluated: nodes, how many edges (loop edges among them), the floor table.
struct EvalMap {
  std::vector<EvalNode> nodes;
  int64_t edges = 0;
  int64_t loop_edges = 0;
  std::vector<EvalLoop> loops;   // from MAP_GRAPH (a store lists constraints, not pairs)
  std::map<int, double> floors;  // index -> height, metres
};

// The map of a MAP_GRAPH message; an error for a non-unit quaternion or a non-finite value.
Expected<EvalMap> mapFromGraph(const map_graph_t& graph);
// The map a store holds (edges: node pairs with at least one accepted constraint).
Expected<EvalMap> mapFromStore(const std::filesystem::path& store);

// What a recorded log of the live pipeline holds for the evaluation.
struct RecordedRun {
  EvalMap map;  // from the last MAP_GRAPH
  bool have_stats = false;
  mapper_stats_t stats{};                             // the last MAPPER_STATS
  std::vector<std::pair<int64_t, core::SE3d>> poses;  // POSE (utime, world_T_body)
  int64_t graphs = 0;
  int64_t undecodable = 0;
};
// Reads an LCM log (lcm-logger's format); an error names the file, or says no MAP_GRAPH is in it.
Expected<RecordedRun> readRecordedRun(const std::filesystem::path& log);

// A pose_t event of a log (POSE, GROUND_TRUTH): the message and its pose. Errors: it does not
// decode, or its pose is not one (the decoder's message).
struct LoggedPose {
  pose_t msg;
  core::SE3d world_T_body;
};
Expected<LoggedPose> decodeLoggedPose(const messages::LogReader::Event& ev);

// The truth of a simulated run: body poses of every session, the floor table, sessions.
struct RunTruth {
  std::map<int64_t, core::SE3d> world_T_body;  // by utime, 10 Hz
  std::map<int, double> floors;                // index -> height, metres
  int sessions = 0;
  // The true pose at `utime`, interpolated in position between the samples around it (nearer
  // sample's rotation); false when no sample lies within 0.25 s on both sides.
  bool at(int64_t utime, core::SE3d* world_T_body) const;
  int floorAt(double z_m) const;  // the floor of nearest height
};
// Reads DIR/session-*.tum and DIR/run.sim.txt; errors name the file.
Expected<RunTruth> readRunTruth(const std::filesystem::path& run_folder);
// The truth of GROUND_TRUTH samples (world_T_body by utime, with the pose_t floor and
// session): floors at the median height of their samples, sessions counted. Errors: fewer
// than 2 samples.
Expected<RunTruth> truthFromSamples(const std::map<int64_t, core::SE3d>& poses,
                                    const std::map<int64_t, std::pair<int, int>>& floor_session);
// The GROUND_TRUTH of LCM logs (the image-level simulator's, a converted data set's).
Expected<RunTruth> readLogTruth(const std::vector<std::filesystem::path>& logs);

struct MapEvaluation {
  int64_t nodes = 0;
  int64_t nodes_with_truth = 0;
  int64_t edges = 0;
  int64_t loop_edges = 0;
  int floors = 0;
  int floors_right = 0;           // of the map's floor table, within 0.25 m of the building's
  int64_t nodes_floor_right = 0;  // floor label = the true floor
  // Floor labels are the map's own (elevator-proc numbers floors from the session's start):
  // nodes whose label maps to their true floor under the one label -> floor assignment that
  // most nodes agree with; and how many labels that assignment has.
  int64_t nodes_floor_consistent = 0;
  int64_t loops_with_truth = 0;               // loop edges whose nodes have truth
  int64_t false_loops = 0;                    // ... off the truth by > 0.5 m or > 5 degrees
  std::vector<std::string> worst_node_lines;  // the 5 nodes furthest off after the alignment
  std::vector<std::string> false_loop_lines;  // each: "A-B: D m, R deg off the truth
  int sessions = 0;                           // distinct sessions among the nodes
  int sessions_truth = 0;
  double ate_rmse_m = 0.0, ate_median_m = 0.0, ate_max_m = 0.0;
  int64_t poses = 0;  // POSE messages with truth
  double pose_ate_rmse_m = 0.0, pose_ate_median_m = 0.0;
  std::string text() const;
  std::string json() const;
};

// `poses` may be empty (no POSE figures). An error when fewer than 3 nodes have truth.
Expected<MapEvaluation> evaluateMap(const EvalMap& map, const RunTruth& truth,
                                    const std::vector<std::pair<int64_t, core::SE3d>>& poses = {});

}  // namespace evermap::mapper
