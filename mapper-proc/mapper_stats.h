#pragma once
// What the mapper counts and how long its parts take: MapperStats, printed by text() (the
// --stats summaries), published as MAPPER_STATS' named counters (lcm_node.h) and listed in
// evermap-slam-run's summary, all from the one list of counters (MapperStats::counters()).

#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace evermap::mapper {

// Per-component time (wall clock, measurement only: never an input to the algorithm).
struct MapperTiming {
  double tracking_s = 0.0;
  double registration_s = 0.0;  // handling results: constraints, Δ replacement
  double partition_s = 0.0;     // cell index rebuild and new-place tests
  double solver_s = 0.0;
  std::vector<double> update_s;       // solver time of each step that changed the graph
  std::vector<int64_t> update_utime;  // message time of each update_s entry
  // Background batch steps (IncrementalOptions::background_batch_lag): how many were swapped
  // in, the worker's time on them (work done off the steps, on another core), and how long
  // the swapping steps waited for the worker — in the offline runner, where message time
  // runs ~2000x faster than in operation; step cost counts only the wait operation would see
  // (the worker's time beyond the message time between start and swap).
  int64_t background_batches = 0;
  double background_batch_s = 0.0;
  double background_wait_s = 0.0;
  // Wall time of the mapper's work for each step (request, result handling, new node,
  // solver update), at the step's keyframe time: the "mapper update" of the paper's Fig. 7.
  struct StepCost {
    int64_t utime;
    double s;
    double cpu_s = 0.0;  // the same work as the step thread's CPU time (no preemption)
  };
  std::vector<StepCost> step_cost;
};

struct MapperStats {
  int64_t steps = 0;
  int64_t nodes = 0;
  int64_t constraints = 0;  // every constraint made (kept in the constraint set)
  int64_t factors = 0;      // node pairs the solver holds factors for
  int64_t merged = 0;
  int64_t rejected_inconsistent = 0;
  int64_t requests_node = 0;
  int64_t requests_global = 0;
  int64_t registrations_ok = 0;
  int64_t loop_closures = 0;      // constraints to another existing node
  int64_t delta_replaced = 0;     // active-node registrations that replaced Δ
  int64_t delta_kept = 0;         // ... that lost the det(Σ) test
  int64_t delta_fused = 0;        // ... fused with Δ (fuse_active_registration)
  int64_t rejected_map_gate = 0;  // registrations that contradicted the map or Δ
  int64_t rejected_floor = 0;     // registrations to a node of another floor
  int64_t footprints = 0;  // places registered from filed as their node's (view_footprints.h)
  int64_t closures_saturated = 0;  // new pairs of saturated nodes below their bound: no factor
  int64_t gate_recoveries = 0;     // ... accepted after all: a second one agreed with them
  int64_t recoveries_too_far = 0;  // ... not: their jump was more than odometry could drift
  int64_t relocalizations = 0;     // a new session tied to the map by a global registration
  int64_t relocalization_disagreements = 0;      // a lost session's registrations that disagreed
  int64_t relocalization_same_frame_checks = 0;  // candidates checked on their own keyframe
  int64_t implausible_floors = 0;                // FLOOR refused by the floor gate (in dropped too)
  int64_t timeouts = 0;
  int64_t dropped = 0;         // malformed, stale or out-of-order messages
  int64_t restored_nodes = 0;  // loaded from a map store by restore()
  int64_t restored_constraints = 0;
  // A restored map's start: tracking resumed from the stored state (warm), or lost (no state,
  // a state too old for warm_restart_max_gap_s, or a ride or a new session announced since).
  int64_t warm_restarts = 0;
  int64_t lost_restarts = 0;
  // After a warm restart: the placement confirmed by two agreeing registrations to the
  // restored map (consistent with the inflated pose), and registrations that contradicted it.
  int64_t warm_confirmations = 0;
  int64_t warm_rejections = 0;
  // Warm restarts whose gap the odometry bridged (MapperOptions::warm_restart_bridge): no
  // confirmation needed; of them, those the wheels' odometry bridged (VO's chain had
  // restarted in the gap), and VO frames set aside after a restart while waiting for the
  // wheel pose to bridge with (at most warm_restart_wheel_wait_s).
  int64_t warm_bridged = 0;
  int64_t warm_bridged_by_wheels = 0;
  int64_t warm_wheel_waits = 0;
  // Restarts near an elevator over a gap a ride fits in: lost, not bridged or inflated.
  int64_t warm_elevator_refusals = 0;
  // A map's first session that no registration ever confirmed (made from traffic that never
  // became consistent), quarantined when the next session began (mapper.h, startSession), its
  // nodes, and registrations to them refused since.
  int64_t sessions_quarantined = 0;
  int64_t nodes_quarantined = 0;
  int64_t registrations_quarantined = 0;
  // A floor's height replaced because later reports contradicted the one in use (floor_state.h).
  int64_t floor_heights_replaced = 0;
  MapperTiming timing;

  // Every counter above, once: its name (text()'s, MAPPER_STATS') and its field.
  struct Counter {
    std::string_view name;
    int64_t MapperStats::*field;
  };
  static const std::array<Counter, 39>& counters();
  // "name value" lines, in counters() order.
  std::string text() const;
  // Adds the counters of another mapper's stats (sessions mapped by successive mappers).
  void addCounters(const MapperStats& other);
};

}  // namespace evermap::mapper
