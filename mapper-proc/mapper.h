#pragma once
// The reduced pose graph mapper: Algorithm 1 of the paper (section III), and the full pose
// graph baseline through the same code (DESIGN.md section 3).
//
// Driven by messages and their time stamps only. At a VO keyframe, at most once every
// step_interval_s of message time, the mapper takes a *step* of Algorithm 1:
//   1. register the keyframe against the node of the current partition cell (the closest
//      node; the active node when the cell is empty) — MODE_NODE;
//   2. if that fails, a global appearance search on the current floor — MODE_GLOBAL;
//   3. a registration to the active node replaces Δ when det(Σ_t^a) > det(Σ_t^b) (or
//      always, right after a loop closure: the re-localisation of section III-B.3); one to
//      another node b adds the constraint a_T_b = Δ_q ⊕ ⊖(b_T_q) between existing nodes and
//      makes b active with Δ = b_T_q ⊕ q_T_now;
//   4. with no registration, a node is added if the estimate x_a ⊕ Δ falls in a
//      (floor, x, y, heading) cell with no node (eq. 8); it becomes active, Δ restarts.
// A registration that contradicts the map or Δ beyond map_gate is rejected (a false match),
// and its step adds no node; when the next rejected one agrees with it through odometry,
// both were right and the map or Δ was wrong: it is accepted after all (gate_recoveries).
// No step is taken during an elevator ride (FLOOR ride start to ride end: the cab moves with
// the robot), and a registration to a node of another floor than the current one is refused.
// Full pose graph mode adds a node at every step before step 1, registers against nodes
// other than the recent ones, and never switches the active node.
//
// Requests go out through takeRequests(); the answer comes back through onRegisterResult(),
// at once (offline runner) or later (LCM). One step is in flight at a time; keyframes
// arriving meanwhile are tracked but take no step. A step whose answer does not come within
// request_timeout_s of message time is closed as "no registration".

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include <evermap/attitude_t.hpp>
#include <evermap/floor_t.hpp>
#include <evermap/node_added_t.hpp>
#include <evermap/register_request_t.hpp>
#include <evermap/register_result_t.hpp>

#include "core/solver/incremental_solver.h"
#include "mapper-proc/constraint_set.h"
#include "mapper-proc/floor_gate.h"
#include "mapper-proc/map_node.h"
#include "mapper-proc/mapper_options.h"
#include "mapper-proc/partition_index.h"
#include "mapper-proc/solver_schedule.h"
#include "mapper-proc/tracker.h"

namespace evermap::mapper {

struct MapSnapshot;  // map_store.h

// What a mapper tracks, saved with the map (map_store.h, table map_tracking) so that a
// restarted mapper can resume where the killed one was (MapperOptions::warm_restart_*).
struct TrackingState {
  int64_t utime = 0;  // message time of the pose: the tracker's newest input
  int session = 0;
  int64_t session_start_utime = -1;
  int64_t active_node = -1;  // the node tracked against
  int floor = 0;
  bool in_elevator = false;           // between a ride's start and end (no warm restart from it)
  core::UncertainPose active_T_body;  // Δ at utime, with its covariance
  // The odometry pose of the VO frame Δ is at (Tracker::odometryAtDelta), when VO tracked
  // and its sender stamps one: a restart whose first VO_DELTA is of the same epoch bridges
  // the gap with the odometry's motion (MapperOptions::warm_restart_bridge).
  std::optional<Tracker::OdometryAnchor> odometry;
  // The wheels' odometry pose (WHEEL_ODOM odom_*) at Δ's time, when their sender stamps one:
  // a restart the VO frame cannot bridge (VO's chain restarted in the gap) is bridged by the
  // wheels' motion when their epoch went on (MapperOptions::warm_restart_bridge).
  std::optional<messages::WheelOdometryPose> wheel;
};

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
  int64_t loop_closures = 0;       // constraints to another existing node
  int64_t delta_replaced = 0;      // active-node registrations that replaced Δ
  int64_t delta_kept = 0;          // ... that lost the det(Σ) test
  int64_t delta_fused = 0;         // ... fused with Δ (fuse_active_registration)
  int64_t rejected_map_gate = 0;   // registrations that contradicted the map or Δ
  int64_t rejected_floor = 0;      // registrations to a node of another floor
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
  MapperTiming timing;
  std::string text() const;
  // Adds the counters of another mapper's stats (sessions mapped by successive mappers).
  void addCounters(const MapperStats& other);
};

class Mapper {
 public:
  explicit Mapper(const MapperOptions& options, int session = 0);

  // Continues a stored map (map_store.h) before any message: its floors, its nodes at their
  // stored estimates, and every stored constraint replayed through the constraint set in
  // stored order (rejections come out as they did), then one solver batch. The
  // origin prior goes on node 0, height factors on every node and the stored roll/pitch
  // factors on their nodes. The mapper is then in a new session (one past the highest stored) and
  // lost: only global registrations until one places it on the map. Its floor is a guess (the
  // newest node's) until a FLOOR message or that re-localisation confirms it: meanwhile every other
  // global search (the first included) covers every floor, and a registration on any floor may
  // place it (a mapper-proc restarted mid-session, on another floor than the one its last session
  // began on). Errors: a mapper that already has nodes, node or edge ids that are not 0..n-1 in
  // order, an edge naming an unknown node. With map.tracking (a state saved by a mapper that
  // tracked), the start is decided at the first VO_DELTA: if it comes at most
  // warm_restart_max_gap_s after the state and no FLOOR message newer than the state announced a
  // ride or a session, tracking resumes from the state's node in its session and floor, Δ's
  // covariance grown by the gap (warm_restart_speed_m_s, warm_restart_turn_rad_s); else the start
  // is lost, as above. Until two agreeing registrations to the restored map confirm the resumed
  // placement, a registration to a restored node makes no closure (it is a candidate, checked
  // against the inflated pose), and POSE is withheld (resumedUnconfirmed()); nodes are added as
  // usual, the first one linked to the state's node by Δ's inflated covariance.
  Status restore(const MapSnapshot& map);
  // The state to save with the map; empty while lost or before the first node.
  std::optional<TrackingState> trackingState() const;
  // A warm restart whose placement on the restored map no registration has confirmed yet.
  bool resumedUnconfirmed() const { return resumed_; }
  // The gap between the saved tracking state and the first VO_DELTA after restore(), seconds,
  // once decided (negative: no saved state usable).
  std::optional<double> restartGapS() const { return restart_gap_s_; }
  // How the restart was decided, for the log: why a warm restart was or was not bridged by
  // odometry ("" before the decision and for a restart without a saved state).
  const std::string& restartNote() const { return restart_note_; }

  // The left camera's mounting (rectified body_T_cam of STEREO_CALIB, calibration_latch.h):
  // VO deltas are camera motions. Until it is set, options.tracker.body_T_cam holds.
  void setCameraMounting(const core::SE3d& body_T_cam) { tracker_.setBodyTCamera(body_T_cam); }

  // Inputs. Each returns an error for a message it drops (also counted).
  Status onVo(const vo_delta_t& msg);
  Status onWheel(const wheel_odom_t& msg);
  Status onAttitude(const attitude_t& msg);
  Status onFloor(const floor_t& msg);
  Status onRegisterResult(const register_result_t& msg);

  // Outputs produced since the last call.
  std::vector<register_request_t> takeRequests();
  std::vector<node_added_t> takeNodesAdded();

  // The current estimate: world_T_body now.
  core::UncertainPose pose() const;
  core::SE3d nodePose(int64_t id) const;
  // Every node made; ids are indices.
  const std::vector<MapperNode>& nodes() const { return nodes_; }
  int64_t graphNodes() const { return static_cast<int64_t>(nodes_.size()); }
  int64_t activeNode() const { return active_; }
  // A new session not yet placed on the map by a global registration: pose() means nothing.
  bool lost() const { return lost_; }
  const ConstraintSet& constraints() const { return constraints_; }
  const solver::IncrementalSolver& solver() const { return schedule_.solver(); }
  const Tracker& tracker() const { return tracker_; }
  const MapperStats& stats() const { return stats_; }
  int floor() const { return floor_; }
  int session() const { return session_; }
  // The session this mapper started with (constructed or restored): later sessions it maps
  // (a gap in VO) are numbered after it. Names the mapper in the map store (map_saved).
  int firstSession() const { return first_session_; }
  // Floor index -> height (metres), as the FLOOR messages reported them.
  const std::map<int, double>& floors() const { return floors_; }

  // The tracked pose at every step: (utime, node, node_T_body). With the final node
  // estimates this gives the trajectory both modes are compared on.
  struct StepPose {
    int64_t utime;
    int64_t node;
    core::SE3d node_T_body;
    int session;
  };
  const std::vector<StepPose>& stepPoses() const { return step_poses_; }

  // The open step's active node and Δ (active_T_keyframe) its registration will be tested
  // against, while one is open: what evaluation compares with the truth (evermap-slam-run).
  struct PendingStep {
    int64_t active;
    core::UncertainPose active_T_keyframe;
  };
  std::optional<PendingStep> pendingStep() const {
    if (!in_flight_) return std::nullopt;
    return PendingStep{in_flight_->active, in_flight_->delta_at_keyframe};
  }

 private:
  struct InFlight {
    int64_t request_id = 0;
    int64_t keyframe_utime = 0;
    int64_t sent_utime = 0;
    int8_t mode = 0;
    int64_t active = -1;
    core::UncertainPose delta_at_keyframe;  // active_T_keyframe
    bool same_frame_check = false;          // a lost robot's candidate checked on its own keyframe
  };

  // Algorithm 1's step (mapper.cpp): the request at a keyframe, and the step's end once its
  // answer is in (a new node at a new place, the solver update).
  void step(int64_t keyframe_utime);
  void finishStep(bool registered);

  // The registration protocol (mapper_registration.cpp).
  void sendRequest(int8_t mode, int64_t target);
  void checkTimeout(int64_t utime);
  // Returns the node to register the same keyframe against next, if any: a lost robot's new
  // candidate checked at once against a node linked to its node (the step stays open).
  std::optional<int64_t> handleRegistration(const register_result_t& msg, const InFlight& f,
                                            const core::Mat6& cam_cov, bool* registered);
  // What a registration b_T_q of the keyframe does: places a lost session (two that agree;
  // returns the same-keyframe check's node, if any), refines Δ (b is the active node), or
  // closes a loop to b.
  std::optional<int64_t> placeLostSession(const InFlight& f, int64_t b,
                                          const core::UncertainPose& b_T_q,
                                          const core::UncertainPose& q_T_now, bool* registered);
  void registerToActive(const InFlight& f, const core::UncertainPose& b_T_q,
                        const core::UncertainPose& q_T_now, bool* registered);
  void closeLoop(const InFlight& f, int64_t b, const core::UncertainPose& b_T_q,
                 const core::UncertainPose& q_T_now, bool* registered);

  // The graph (mapper.cpp): nodes, factors and constraints, gathered for the solver's next
  // update (flushSolver: the step's end; a full-graph step's node before its request too).
  int64_t addNode(int64_t keyframe_utime, const core::UncertainPose& active_T_node);
  // The partial factor of IMU roll and pitch on a node (false: a covariance it cannot use).
  bool addAttitudeFactor(int64_t id, const NodeAttitude& attitude);
  // vetted: a loop closure the map gate has tested against the map (no robust kernel).
  void addConstraint(int64_t from, int64_t to, const core::UncertainPose& from_T_to,
                     ConstraintKind kind, int64_t utime, bool vetted = false);
  // The registration protocol's tests against the map and odometry (mapper_registration.cpp).
  // information (when given): the closure's mutual information with the map, nats
  // (MapperOptions::saturated_closure_information); infinity without a marginal.
  bool consistentWithMap(int64_t a, int64_t b, const core::UncertainPose& a_T_b,
                         double* information = nullptr);
  // The map's estimate of a_T_b with its marginal covariance (the joint marginal of a and b
  // through the relative-pose Jacobians); empty when the solver gives no marginal.
  std::optional<core::UncertainPose> mapRelative(int64_t a, int64_t b) const;
  struct RelocalizationCandidate;
  // While lost with a candidate placement: the node to check it against (step), if any.
  std::optional<int64_t> relocalizationCheck(int64_t keyframe_utime);
  // A node the map links to `node` (a constraint between them) whose view overlaps the
  // placement world_T_body (within overlap_heading_sectors of its heading), the nearest.
  std::optional<int64_t> linkedNeighbour(int64_t node, const core::SE3d& world_T_body) const;
  // Whether the registration b_T_q of the keyframe agrees, chained by odometry, with an
  // earlier one (candidate) on where the robot is.
  bool confirmsRelocalization(int64_t b, const core::UncertainPose& b_T_q, int64_t keyframe_utime,
                              const std::optional<RelocalizationCandidate>& candidate);
  // A registration the map gate rejects: true when it confirms the previous rejected one
  // (then both were right and the map or Δ was wrong) and its jump_m is a drift odometry could
  // have made (MapperOptions::recovery_slack_m); otherwise it becomes the candidate.
  bool confirmsRejected(int64_t b, const core::UncertainPose& b_T_q, int64_t keyframe_utime,
                        double jump_m);
  // How far apart the map puts the keyframe q through a (Δ = a_T_q) and through b (b_T_q).
  double jumpM(int64_t a, const core::UncertainPose& a_T_q, int64_t b,
               const core::UncertainPose& b_T_q) const;
  // Gaps odometry bridged so far (tracker counts and rides), and whether a gate recovery may
  // override Δ now (MapperOptions::recovery_quiet_s).
  int64_t bridges() const;
  bool recoveryAllowed(int64_t keyframe_utime) const;
  // The step's changes to the solver (solver_schedule.h), and the partition index after them.
  void flushSolver();
  // The step at a keyframe VO moved its reference to (Algorithm 1), when one is due.
  void stepAtKeyframe(int64_t keyframe_utime);
  // The keyframe step the tracker held for its heading, taken now (by a message at now_utime),
  // and the mapper's step at it unless a session starts or the step is stale.
  void takeHeldStep(int64_t now_utime, bool session_starts = false);
  void recordFlush(const SolverSchedule::Flush& flush);
  // The node of the place world_T_body is in (partition_index.h).
  std::optional<int64_t> nodeAt(const core::SE3d& world_T_body, int floor,
                                int64_t newest_allowed) const;
  // A new session (FLOOR with EVENT_NONE, or a gap in VO time): lost until re-localised.
  void startSession(int64_t utime);
  // The map's label for the floor a ride ended on at height_m (FLOOR's reported label):
  // the floor of the map's table at that height, else the reported label if the map has no
  // floor by it, else a new label.
  int floorAtHeight(int reported, double height_m) const;

  // The warm-restart decision at the first VO_DELTA after restore() (mapper.cpp).
  void decideRestart(const vo_delta_t& msg);
  // The motion over a restart's gap from the odometry frame, from the state's VO frame to
  // msg's (saved_T_now, body frames), when the bridge may cross it; else empty, and `why`
  // says why not.
  std::optional<core::UncertainPose> odometryBridge(const TrackingState& s, const vo_delta_t& msg,
                                                    std::string& why) const;
  // The same from the wheels' odometry frame, to the first VO_DELTA's time `utime`; why not
  // (if not) in `why`.
  std::optional<core::UncertainPose> wheelBridge(const TrackingState& s, int64_t utime,
                                                 std::string& why) const;
  // Whether the restart decision waits for the wheels: the saved state holds a wheel pose, VO
  // cannot bridge, no wheel pose at msg's time has arrived yet, and the wait is not over.
  bool waitForWheels(const vo_delta_t& msg);
  // The node at an end of a ride (an odometry constraint between floors) closest in x-y to
  // `world_T_body` within warm_restart_elevator_radius_m, and its distance; empty if none.
  std::optional<std::pair<int64_t, double>> elevatorNear(const core::SE3d& world_T_body) const;
  // A registration to a restored node while resumedUnconfirmed() (mapper_registration.cpp).
  std::optional<int64_t> confirmResumed(const InFlight& f, int64_t b,
                                        const core::UncertainPose& b_T_q,
                                        const core::UncertainPose& q_T_now, bool* registered);

  MapperOptions o_;
  int session_;
  int first_session_;
  PartitionIndex partition_;
  Tracker tracker_;
  ConstraintSet constraints_;
  SolverSchedule schedule_;
  std::vector<MapperNode> nodes_;
  int64_t active_ = -1;
  bool relocalize_ = false;   // after a loop closure: the next registration to b replaces Δ
  bool lost_ = false;         // a new session that no global registration has placed yet
  double step_cost_s_ = 0.0;  // wall time of the step in progress so far
  double step_cpu_s_ = 0.0;   // ... and CPU time of the mapper's thread
  // While lost: the last registration to the map, waiting for a second one that agrees.
  struct RelocalizationCandidate {
    int64_t node;
    core::UncertainPose node_T_keyframe;
    int64_t keyframe_utime;
    int verifications = 0;  // node-mode requests sent to check it (step)
  };
  std::optional<RelocalizationCandidate> relocalization_candidate_;
  // The last registration the map gate rejected, waiting for a second one that agrees.
  std::optional<RelocalizationCandidate> rejected_candidate_;
  bool gate_rejected_ = false;  // the step in flight had a registration the gate rejected
  int floor_ = 0;
  bool floor_confirmed_ = true;  // false: a restored map's guess (restore(), sendRequest)
  int64_t unconfirmed_searches_ = 0;
  double floor_height_m_ = 0.0;
  std::map<int, double> floors_;
  bool have_floor_ = false;
  bool in_elevator_ = false;               // between a ride's start and end: no steps
  int64_t rides_ = 0;                      // ride ends seen
  int64_t last_confirmed_utime_ = -1;      // keyframe of the last accepted registration
  int64_t bridges_at_confirmation_ = 0;    // bridges() then
  double odometer_at_confirmation_ = 0.0;  // tracker_.odometerM() then
  std::optional<attitude_t> attitude_;
  int64_t last_step_utime_ = -1;
  int64_t last_floor_utime_ = -1;
  FloorGate floor_gate_{o_.floor_gate};
  int64_t last_vo_utime_ = -1;
  int64_t session_start_utime_ = -1;  // utime of the message that started the session
  int64_t last_attitude_utime_ = -1;
  int64_t next_request_id_ = 1;
  std::optional<InFlight> in_flight_;
  std::optional<TrackingState> saved_tracking_;  // restore()'s, until decideRestart()
  bool resumed_ = false;                         // warm restart, placement not confirmed yet
  std::optional<double> restart_gap_s_;
  int64_t restart_first_vo_utime_ = -1;  // the first VO_DELTA after a restart (waitForWheels)
  std::string restart_note_;
  int64_t resume_first_new_node_ = 0;  // nodes from this id on were made after the restart
  std::vector<register_request_t> requests_;
  std::vector<node_added_t> nodes_added_;
  std::vector<StepPose> step_poses_;
  MapperStats stats_;
};

}  // namespace evermap::mapper
