#pragma once
// The mapper's options: every mapper.* setting of mapper-proc, evermap-mapper-run and
// evermap-slam-run (read by mapper_config.h), with its default, unit and meaning.

#include "core/common/expected.h"
#include "core/common/option_fields.h"
#include "core/solver/incremental_solver.h"
#include "mapper-proc/floor_gate.h"
#include "mapper-proc/localizer_options.h"
#include "mapper-proc/tracker.h"

namespace evermap::mapper {

// The mapper's solver: iSAM's schedule (GN, a batch step every 100 updates) with the two
// changes that keep a step's cost from growing with the map (docs/mapper.md, "Step cost"):
// partial back substitution (a change under 1 mm / 1 mrad stops propagating: iSAM2's
// wildfire, at GTSAM's default threshold) and the scheduled batch steps computed in the background,
// swapped in 10 updates (at least 5 s of message time at 2 Hz steps) after they start.
inline solver::IncrementalOptions mapperSolverOptions() {
  solver::IncrementalOptions o;
  o.wildfire_threshold = 1e-3;
  o.background_batch_lag = 10;
  return o;
}

struct MapperOptions {
  // false: the reduced pose graph; true: a node at every step (the paper's baseline).
  bool full_graph = false;
  // Partition of each floor (paper section IV-B): cell edge in metres, heading sectors.
  double cell_size_m = 1.0;
  int heading_bins = 8;
  // Overlapping poses (the introspection the paper's conclusion proposes): a node whose
  // estimate lies within overlap_radius_cells × cell_size_m and overlap_heading_sectors × a
  // heading sector of the step's estimate shows the same place even when a cell edge (x, y
  // or a sector's) lies between them. When the estimate's own cell is empty the step
  // registers against the closest such node, and no node is added while one overlaps
  // (docs/mapper.md, "A year"). 0: the cells alone (eq. 8). The radius is at most 3 cells
  // (registrations reach a few metres; the cells within it are searched), the heading
  // tolerance at most a sector.
  double overlap_radius_cells = 1.0;
  double overlap_heading_sectors = 1.0;
  // Footprints (view_footprints.h): a place the robot registered to a node from, where no
  // node is, is filed as that node's; a step there asks that node, and adds no node.
  bool footprints = true;
  // While lost, a registration that places the robot (a candidate, waiting for a second one
  // that agrees) is checked by up to this many node-mode requests to the node where it says
  // the robot is now, before global searches resume. 0: global searches only.
  int relocalization_checks = 2;
  // Steps at VO keyframes at most this often, seconds of message time (loopclose-proc's 2 Hz).
  double step_interval_s = 0.5;
  // An unanswered registration closes after this long, seconds of message time.
  double request_timeout_s = 5.0;
  // A gap this long between VO messages starts a new session, as the FLOOR message that
  // opens one does: over UDP that single message can be lost, and a session mapped as the
  // continuation of the previous one would be placed wherever the last one ended.
  double session_gap_s = 600.0;
  // χ² gate (6 dof) for constraints of one pair to be merged; 16.81 = 99 %.
  double consistency_gate = 16.81;
  // Full graph: nodes added within this many seconds before the step are not loop targets.
  double recent_exclusion_s = 20.0;
  // Added to every constraint covariance's diagonal before inversion (m², rad²).
  double covariance_floor = 1e-10;
  // Prior on the first node: standard deviations, metres and radians.
  double origin_sigma_m = 1e-3;
  double origin_sigma_rad = 1e-3;
  // Partial factors: IMU roll/pitch and floor heights on each node.
  bool attitude_factors = true;
  bool height_factors = true;
  // Robust kernel (DCS, Agarwal et al. 2013) on a loop closure that opens its node pair and
  // that the map gate did not test (full graph mode, map_gate = 0): its only guard against a
  // false match.
  solver::RobustKernel loop_kernel{solver::KernelType::kDcs, 20.0};
  // The kernel on a closure that passed the map gate (none: see Mapper::addConstraint).
  solver::RobustKernel vetted_loop_kernel{solver::KernelType::kNone, 20.0};
  // χ² gate (6 dof) of a registration against what the map already says: a closure's a_T_b
  // against the map estimate with its marginal covariance, an active-node registration
  // against Δ. Catches false matches the per-pair test cannot see (a pair's first
  // constraint). 0 disables; 22.46 = 99.9 %.
  double map_gate = 22.46;
  // Partners per node (docs/mapper.md, "A year"): a loop closure that would open a new pair
  // between two nodes that both already belong to at least closure_partners pairs (of any
  // kind: a node of a chain has two odometry partners) is added only when its mutual
  // information with the map's estimate of the pair,
  //   I = ½ ln det(Σ_map + Σ_z) / det(Σ_z)  (nats; Ila, Porta & Andrade-Cetto 2010),
  // reaches saturated_closure_information; below, the
  // robot is re-localised on b and no factor is added. A node with fewer partners always
  // takes the pair, so a new node, a weakly tied one, or a part of the map that nothing else
  // ties keeps every closure; a pair opened below the bound raises a node's count toward
  // it, so the pairs opened without the test are at most closure_partners × nodes (those
  // factors grow with the nodes, not with the visits), while the pairs that tell the map
  // much (a long loop closed after drift) still open. 0: no bound. Needs the map gate (its
  // marginal; without it every closure opens its pair).
  // 3 and 1 nat (docs/mapper.md, "A year": the sweep): a node of a chain takes one loop
  // partner whatever it says; beyond, a pair opens when det(Σ_map + Σ_z) / det(Σ_z) ≥ e²,
  // i.e. unless the map already knows the pair better than the registration (its variance
  // below ~0.4 of the registration's per degree of freedom, geometric mean).
  int closure_partners = 3;
  double saturated_closure_information = 1.0;
  // ... and a node takes a pair freely (below closure_partners) only while it is new: in
  // this many sessions, counting the one that made it. A node's first loop ties come in the
  // session that made it and the next (89 % of them in a year run's first 10 h); a node of
  // an older session that still has two partners is a link of a chain the robot has tracked
  // along in many sessions, and a pair it opens then tells the map little (median 0.55 nat),
  // while opening one at every later passage kept the factors growing with the robot's time
  // (docs/results/mapper.md, "Free pairs only for new nodes"). Raise it when part of the map
  // may not be seen again in the next session (sessions much shorter than a tour of the map,
  // a floor explored per session before the patrols: docs/mapper.md). 0: in every session.
  int closure_partner_sessions = 2;
  // A constraint that merges into a pair the solver already has a factor of enters the
  // solver at the next consolidation (with the scheduled batch steps) instead of as an
  // incremental update of its own.
  bool defer_merges = true;
  // After a background batch step is swapped in, the partition index is refreshed for this
  // many nodes per step (a whole rebuild at once costs O(nodes) in one step).
  int cell_refresh_per_step = 200;
  // A registration to the active node and the tracked Δ are two independent estimates of
  // the same pose: true fuses them (information-weighted, the recursive estimate of eq. 5);
  // false keeps the one with the smaller det(Σ) (the paper's entropy test, III-B.3), which
  // throws the other away. After a loop closure the registration always replaces Δ.
  // A false match that passes the Δ gate is fused in and shrinks Δ's covariance around the
  // wrong value; the gate recovery (two rejected registrations that agree replace Δ) is the
  // way back, without which the gate would reject every true registration after it.
  bool fuse_active_registration = true;
  // A gate recovery overrides Δ only when odometry bridged a gap (wheel odometry, a VO
  // restart, an elevator ride) since the last registration that confirmed it, or when none
  // has confirmed it for this long (seconds of message time): repeated texture makes false
  // matches that agree with each other, and a Δ that registrations keep confirming is not the
  // one that is wrong.
  double recovery_quiet_s = 3.0;
  // ... and only when the jump it makes (how far the registrations put the robot from where
  // the map and Δ put it) is one odometry could have made since the last confirmed
  // registration: at most recovery_slack_m + recovery_drift_fraction × the distance travelled
  // since (Tracker::odometerM). A repeated texture (a floor pattern of period 12 m) makes
  // registrations that agree with each other on a place one period away; odometry does not
  // drift by a period in a few metres.
  double recovery_slack_m = 3.0;
  double recovery_drift_fraction = 0.15;
  // A ride's end is on the map's floor whose height is within this of the ride's measured
  // height (the map's label, whatever a restarted elevator-proc numbers it), metres.
  double floor_match_m = 1.0;
  // Warm restart (docs/mapper.md, "Restarts"): a mapper restored from a store that holds its
  // tracking state (TrackingState) resumes tracking from the saved node instead of starting
  // lost, when the first VO_DELTA after the restart is at most this many seconds of message
  // time after the saved state. 0: never (every restart starts lost, the odometry bridge's
  // too). 10 s: a restart under
  // the deputy takes 0.3 s of wall time, i.e. 6 s of message time in a 20x replay; beyond
  // 10 s the inflated pose (below, 15 m and a full turn) no longer says where the robot is.
  double warm_restart_max_gap_s = 10.0;
  // How far the robot may have gone while nothing was tracked: the saved pose's standard
  // deviation grows by this much per second of the gap, linearly (a displacement bounded by
  // a speed, not a random walk). 1.5 m/s: over twice the simulated robot's cruise (0.55 m/s
  // ±15 %) and above a walking pace, so the true displacement lies within 1σ; 0.5 rad/s: the
  // mean turn rate over seconds of a robot that turns in place at 0.8 rad/s (the simulator's)
  // between straight legs (heading σ capped at π: beyond, the heading is simply unknown).
  double warm_restart_speed_m_s = 1.5;
  double warm_restart_turn_rad_s = 0.5;
  // Until the resumed placement is confirmed, a node is added only while Δ's position
  // standard deviation (the larger of x and y) is at most this, metres: a node is placed in
  // the cell its estimate falls in, and a place chosen metres off is a node nothing may
  // correct (the chain made from it floats on the inflated edge until a closure ties it to
  // the map, if one ever does). 1.5 m: a restart at 1x (0.3 s, plus up to a step, 0.5 s, since
  // the state was saved) adds nodes at once; a 20x replay's 10 s gap (σ 15 m) waits for the
  // confirmation.
  double warm_restart_node_sigma_m = 1.5;
  // Plausibility of FLOOR content (floor_gate.h): heights and vertical speeds no elevator
  // makes are refused and counted (implausible_floors).
  FloorGateOptions floor_gate;
  // The odometry bridge (docs/mapper.md, "Warm restart"): when the saved state holds the
  // odometry pose of its VO frame (VO_DELTA odom_*) and the first VO_DELTA after the restart
  // carries one of the same epoch (VO's chain went on through the gap), the motion over the
  // gap is theirs, odom_saved⁻¹ odom_now, with the covariance the tracker would have
  // compounded from the messages it missed (odometryBetween), and not the inflation above:
  // tracking goes on as if nothing had been lost (nodes at once, closures through the map
  // gate, POSE). Refused (the inflation and the confirmation instead) for a motion faster
  // than tracker.max_speed_m_s / max_turn_rad_s over the gap or with a vertical part beyond
  // floor_match_m (a ride the mapper did not hear of).
  bool warm_restart_bridge = true;
  // The longest gap the bridge crosses, seconds of message time. The odometry's covariance
  // covers its drift at any length; what the bound is for is what odometry does not see and
  // the restarted mapper did not hear: a ride whose FLOOR messages came while it was down, in a
  // cab that VO sees standing still. A ride takes longer (the simulator's cab waits 4 s at
  // each door, a floor is 3-4 m at 1-2 m/s: 12 s and more door to door), and 20x replays lose
  // 7-23 s in a restart under the deputy.
  double warm_restart_bridge_max_gap_s = 30.0;
  // A restart that VO cannot bridge sets VO frames aside for at most this long (seconds of
  // message time) until a wheel pose at their time has arrived (two WHEEL_ODOM messages:
  // 0.2 s at 10 Hz), so that the wheels can bridge it. 0: no wait.
  double warm_restart_wheel_wait_s = 1.0;
  // A ride the restarted mapper did not hear of (its FLOOR messages came while it was down)
  // is what neither bridge can see: the wheels are planar, and VO sees a closed cab standing
  // still. So a gap of at least warm_restart_ride_min_s (to enter a cab, ride and leave it:
  // two door waits of 3-4 s and a floor of 3-4 m at 1-2 m/s) that starts or ends within
  // warm_restart_elevator_radius_m (in x-y: the cab and its door; the nodes at a ride's ends
  // lie in the cab) of an elevator the map knows (a node at either end of an odometry
  // constraint between floors) is not resumed: the restart is lost. 0 m: no such guard.
  double warm_restart_elevator_radius_m = 3.0;
  double warm_restart_ride_min_s = 10.0;
  TrackerOptions tracker;
  LocalizerOptions localize;  // localization mode only (localizer.h)
  solver::IncrementalOptions solver = mapperSolverOptions();

  // Every setting once, with its unit, range and doc (core/common/option_fields.h); keys
  // are read with the prefix "mapper.". full_graph and tracker.body_T_cam are the programs'.
  void declareOptions(OptionList& o);
  // checkOptionRanges, then the rules that tie fields together.
  Status validate() const;

 private:
  void declarePlaces(OptionList& o);
  void declareSteps(OptionList& o);
  void declareClosures(OptionList& o);
  void declareRecovery(OptionList& o);
  void declareWarmRestart(OptionList& o);
};

// The mapper.solver.* settings of the mapper's IncrementalOptions.
void declareSolverOptions(OptionList& o, solver::IncrementalOptions* s);

}  // namespace evermap::mapper
