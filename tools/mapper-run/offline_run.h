#pragma once
// The mapper, the measurement-level simulator and the registration oracle in one process
// (DESIGN.md section 1: the offline runner used by tests, benchmarks and evaluation). The
// simulator's messages reach the mapper in time order, exactly the bytes a log would hold;
// each REGISTER_REQUEST is answered by the oracle as soon as the oracle knows the query
// keyframe (its KEYFRAME message follows the VO_DELTA that made it), each NODE_ADDED is told
// to the oracle likewise. Deterministic: same options, same result.
//
// Continuing a map: with a store that holds nodes, the mapper restores it (Mapper::restore)
// and the run resumes after the newest keyframe the store mentions (of a node or an edge). Sessions
// before the mapped range and messages before that point are still simulated for the oracle, which
// learns the stored nodes' keyframes from them, but reach the mapper only as FLOOR messages (the
// floor the robot is on). A run killed at any moment is thereby resumed by running it again.

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "core/common/progress.h"
#include "core/common/expected.h"
#include "core/geometry/se3.h"
#include "mapper-proc/mapper.h"
#include "tools/sim/sim_options.h"

namespace evermap::mapper {

// One row of the timeline: the state after `operating_s` of simulated operation (session
// durations summed; the months between sessions do not count, as in the paper's Fig. 7).
struct TimelineRow {
  double operating_s = 0.0;
  int64_t utime = 0;
  int session = 0;
  int64_t nodes = 0;  // in the graph, restored ones included
  int64_t factors = 0;
  int64_t steps = 0;        // in this window
  double tracking_s = 0.0;  // wall time in this window, per component
  double registration_s = 0.0;
  double partition_s = 0.0;
  double solver_s = 0.0;
  double step_median_ms = 0.0;  // mapper work per step in this window (MapperTiming::step_cost)
  double step_p99_ms = 0.0;
  double step_max_ms = 0.0;
  // With a map store (OfflineRunOptions::store_file), else -1: rows of map_edges, and the
  // file's bytes (database and write-ahead log).
  int64_t store_rows = -1;
  int64_t store_bytes = -1;
  // The views the true poses of the keyframes so far need (run_metrics.h, ViewCover; those
  // of sessions a stored map holds included), -1 when not counted.
  int64_t views = -1;
};

// After every map store transaction.
struct StoreCommit {
  int64_t nodes = 0;      // committed in the file
  int64_t edges = 0;      // the mapper's constraints
  int64_t edge_rows = 0;  // rows of map_edges (constraints, folded ones as one)
  int64_t utime = 0;      // message time of the update
};

struct OfflineRunOptions {
  std::filesystem::path store_file;  // empty: no map store
  // 0: a transaction after every message that changed the map (as mapper-proc); > 0: at most
  // one per this many seconds of operating time, and one at the end (long runs, where the
  // store's fsyncs would take most of the wall time).
  double store_period_s = 0.0;
  // The sessions of the simulated run that are mapped, inclusive; -1: to the last.
  int first_session = 0;
  int last_session = -1;
  // Timeline rows every this many seconds of operation (0: none).
  double timeline_interval_s = 60.0;
  // A node counts as "in a mapped area" when a node of an earlier session lies within this
  // distance and heading difference of it, both at their true poses.
  double revisit_radius_m = 1.0;
  double revisit_angle_rad = 0.3927;  // π/8: half a heading sector of the partition
  std::function<void(const StoreCommit&)> on_commit;
  // > 0: stop mapping after this much wall time (the rest of the run is not simulated); the
  // summary then covers the operating time reached. For graphs that outgrow the machine.
  double max_wall_s = 0.0;
  // > 0: stop mapping after this much operating time of the mapped sessions (message time:
  // deterministic), as a process killed then would.
  double stop_after_s = 0.0;
  // With a stored map: the FLOOR messages before the resume point reach the restored mapper,
  // as a log replayed from the session's start would bring them; false: none do, as for a
  // mapper-proc restarted live (it learns its floor from the map when it relocalises).
  bool floors_before_resume = true;
  // With a stored map: the messages of this many seconds after the resume point (the newest
  // keyframe or tracking state the store holds) do not reach the mapper, as those sent while
  // mapper-proc restarts do not (MapperOptions::warm_restart_max_gap_s).
  double restart_gap_s = 0.0;
  // A progress line on stderr at most this often, seconds of wall time (0: none).
  double progress_period_s = kProgressPeriodS;

  Status validate() const;
};

struct OfflineRunSummary {
  MapperStats stats;
  int64_t nodes = 0;
  std::vector<int64_t> nodes_by_session;
  // Nodes of each session placed where an earlier session (restored ones included) had a
  // node (OfflineRunOptions::revisit_*), at their true poses.
  std::vector<int64_t> nodes_in_mapped_area_by_session;
  // The other causes of a session's new nodes (run_metrics.h, PlaceCause; same test): a
  // mapped place seen at a new heading, and a place no earlier session had a node near.
  std::vector<int64_t> nodes_new_heading_by_session;
  std::vector<int64_t> nodes_new_place_by_session;
  // Of the nodes that are not duplicates: those with an earlier session's node within twice
  // the radius and the angle (2 m and 45° by default, at their true poses): a place the
  // earlier sessions passed facing that way without leaving it a node within reach (issue
  // 22: the late nodes of Algorithm 1, which adds a node only where a registration failed).
  std::vector<int64_t> nodes_near_a_view_by_session;
  // The new views each session's keyframes met at their true poses (run_metrics.h,
  // ViewCover, at the overlap's reach): how much of the building a session saw first, which
  // the map's node growth after exploration is held against.
  std::vector<int64_t> views_by_session;
  // Node pairs whose nodes are on different floors (the rides' constraints, at the nodes'
  // true floors) and how far their merged estimates are off in yaw from the truth, rms,
  // against the yaw σ they claim, rms (degrees): what turns a floor against the others.
  int64_t interfloor_pairs = 0;
  double interfloor_yaw_rms_deg = 0.0;
  double interfloor_yaw_claimed_deg = 0.0;
  // Node pairs (the solver's factors) opened in each session, by the session of the
  // constraint that opened them: all, and those between two nodes of earlier sessions (what
  // a visit adds to a mapped area without adding a node; issue 22: factors that grow with
  // the visits).
  std::vector<int64_t> pairs_by_session;
  std::vector<int64_t> pairs_between_earlier_nodes_by_session;
  // Step poses of each session, and those where an earlier session had a node (same test):
  // how much of the session revisited mapped areas.
  std::vector<int64_t> steps_by_session;
  std::vector<int64_t> steps_in_mapped_area_by_session;
  int64_t restored_nodes = 0;
  std::string restart_note;    // Mapper::restartNote() of a restored map's start
  bool stopped_early = false;  // OfflineRunOptions::max_wall_s or stop_after_s reached
  int final_floor = -1;        // the mapper's floor at the end (-1: not known)
  double operating_s = 0.0;    // operating time mapped
  double wall_s = 0.0;         // wall time of the whole run
  int64_t factors = 0;         // pair factors in the solver
  int64_t constraints = 0;     // every constraint kept
  int64_t messages = 0;        // simulator messages delivered
  int64_t decode_errors = 0;
  int64_t false_matches = 0;  // oracle answers that were false matches
  int64_t step_poses = 0;
  double ate_rmse_m = 0.0;  // step poses with the final node estimates, SE(3)-aligned
  double ate_median_m = 0.0;
  double duration_s = 0.0;  // simulated time, mapped sessions
  double distance_m = 0.0;
  double update_median_ms = 0.0;  // solver updates
  double update_p99_ms = 0.0;
  // Mapper work per step (MapperTiming::step_cost): over the run, its first and its last hour
  // of operating time (the "update p99, last hour against first").
  double step_median_ms = 0.0;
  double step_p99_ms = 0.0;
  double step_p99_first_hour_ms = 0.0;
  double step_p99_last_hour_ms = 0.0;
  // The same from the mapper thread's CPU time: without preemption by other processes and
  // threads (this machine's 2 cores are shared), i.e. the work itself.
  double step_cpu_p99_first_hour_ms = 0.0;
  double step_cpu_p99_last_hour_ms = 0.0;
  int64_t nodes_4h_before_end = 0;  // graph size 4 h of operating time before the end
  int64_t store_transactions = 0;   // with a map store: one per update that changed the graph
  double store_s = 0.0;             // wall time spent writing them
  std::vector<TimelineRow> timeline;
  // For plots: the step poses (ground truth and aligned estimate) and the nodes (ground
  // truth of their keyframes' body poses and aligned estimates), world frame, metres.
  std::vector<core::Vec3> trajectory_gt, trajectory_est, nodes_gt, nodes_est;
  // Where the error is: each step pose and each node (true keyframe pose known) with its
  // translation error after the ATE's alignment (writeErrorsCsv).
  struct StepError {
    int64_t utime = 0;
    int session = 0;
    int64_t node = 0;     // the node the step pose hangs on
    int true_floor = -1;  // -1: unknown
    double error_m = 0.0;
    double yaw_error_deg = 0.0;  // estimated minus true heading, (-180, 180]
  };
  struct NodeError {
    int64_t id = 0;
    int session = 0;
    int floor = 0;  // as the mapper assigned it
    int64_t keyframe_utime = 0;
    double error_m = 0.0;
    core::SE3d world_T_body_true;  // the true body pose at the node's keyframe
  };
  std::vector<StepError> step_errors;
  std::vector<NodeError> node_errors;
  std::string text() const;
};

// Simulates `sim` and maps it. Errors: invalid options, the store, or too few step poses for
// an ATE.
Expected<OfflineRunSummary> runOffline(const sim::SimOptions& sim, MapperOptions mapper,
                                       const OfflineRunOptions& run);
Expected<OfflineRunSummary> runOffline(const sim::SimOptions& sim, MapperOptions mapper,
                                       const std::filesystem::path& store_file = {});

// The timeline as CSV with a header line, written through a temporary file and a rename.
Status writeTimelineCsv(const std::filesystem::path& file, const std::vector<TimelineRow>& rows);
// The per-step and per-node errors as two CSV files with header lines (steps_file,
// nodes_file), each written through a temporary file and a rename.
Status writeErrorsCsv(const std::filesystem::path& steps_file,
                      const std::filesystem::path& nodes_file, const OfflineRunSummary& summary);
// Reads what writeTimelineCsv wrote. Errors name the file and line.
Expected<std::vector<TimelineRow>> readTimelineCsv(const std::filesystem::path& file);

}  // namespace evermap::mapper
