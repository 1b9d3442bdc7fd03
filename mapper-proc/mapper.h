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

#include "core/common/clocks.h"
#include "core/solver/incremental_solver.h"
#include "mapper-proc/constraint_set.h"
#include "mapper-proc/floor_state.h"
#include "mapper-proc/gate_recovery.h"
#include "mapper-proc/map_gate.h"
#include "mapper-proc/map_inputs.h"
#include "mapper-proc/map_node.h"
#include "mapper-proc/mapper_options.h"
#include "mapper-proc/mapper_stats.h"
#include "mapper-proc/partition_index.h"
#include "mapper-proc/view_footprints.h"
#include "mapper-proc/solver_schedule.h"
#include "mapper-proc/tracker.h"
#include "mapper-proc/warm_restart.h"

namespace evermap::mapper {

class Mapper : public MapConsumer {
 public:
  explicit Mapper(const MapperOptions& options, int session = 0);

  // Continues a stored map (core/map/map_snapshot.h) before any message: its floors, its nodes at
  // their stored estimates, and every stored constraint replayed through the constraint set in
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
  bool resumedUnconfirmed() const { return warm_.unconfirmed(); }
  // The gap between the saved tracking state and the first VO_DELTA after restore(), seconds,
  // once decided (negative: no saved state usable).
  std::optional<double> restartGapS() const { return warm_.gapS(); }
  // How the restart was decided, for the log: why a warm restart was or was not bridged by
  // odometry ("" before the decision and for a restart without a saved state).
  const std::string& restartNote() const { return warm_.note(); }

  // Inputs (map_inputs.h).
  Status onVo(const vo_delta_t& msg) override;
  Status onWheel(const wheel_odom_t& msg) override;
  Status onAttitude(const attitude_t& msg) override;
  Status onFloor(const floor_t& msg) override;
  Status onRegisterResult(const register_result_t& msg) override;

  // Outputs produced since the last call (and takeRequests(), map_inputs.h).
  std::vector<node_added_t> takeNodesAdded();
  // One line for each recovery from traffic that never became consistent (a session
  // quarantined, a floor's height replaced), since the last call.
  std::vector<std::string> takeNotes();

  // The current estimate: world_T_body now.
  core::UncertainPose pose() const;
  core::SE3d nodePose(int64_t id) const { return schedule_.pose(id); }
  // Every node made; ids are indices.
  const std::vector<MapperNode>& nodes() const { return nodes_; }
  // The places registered from, filed as their nodes' (view_footprints.h), in the order made.
  const std::vector<Footprint>& footprints() const { return footprints_.all(); }
  int64_t activeNode() const { return active_; }
  // A new session not yet placed on the map by a global registration: pose() means nothing.
  bool lost() const { return lost_; }
  // A node of a quarantined session (startSession): kept in the graph, no place of the map.
  bool quarantined(int64_t id) const {
    return id >= 0 && static_cast<size_t>(id) < quarantined_.size() &&
           quarantined_[static_cast<size_t>(id)];
  }
  const ConstraintSet& constraints() const { return constraints_; }
  const solver::IncrementalSolver& solver() const { return schedule_.solver(); }
  const MapperStats& stats() const { return stats_; }
  int floor() const { return floors_.floor(); }
  int session() const { return session_; }
  // The session this mapper started with (constructed or restored): later sessions it maps
  // (a gap in VO) are numbered after it. Names the mapper in the map store (map_saved).
  int firstSession() const { return first_session_; }
  // Floor index -> height (metres), as the FLOOR messages reported them.
  const std::map<int, double>& floors() const { return floors_.table(); }

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
    std::optional<Footprint> view;          // the step's registration: node_T_keyframe
  };

  // Algorithm 1's step (mapper.cpp): the request at a keyframe (to the node of the place
  // the estimate is in, else a global search), and the step's end once its answer is in (a
  // new node at a new place, the solver update).
  void step(int64_t keyframe_utime);
  std::optional<int64_t> stepTarget(int64_t keyframe_utime, const core::SE3d& world_T_body);
  void finishStep(bool registered);
  // The step at a keyframe VO moved its reference to, when one is due.
  void stepAtKeyframe(int64_t keyframe_utime);
  // The keyframe step the tracker held for its heading, taken now (by a message at now_utime),
  // and the mapper's step at it unless a session starts or the step is stale.
  void takeHeldStep(int64_t now_utime, bool session_starts = false);
  // A new session (FLOOR with EVENT_NONE, or a gap in VO time): lost until re-localised. A
  // map whose first session no registration ever confirmed (made from traffic that never became
  // consistent: forged or corrupt odometry, a stranger's keyframes) holds nothing to re-localise
  // on: that session is quarantined (quarantineOrigin) and the new one starts the map afresh.
  void startSession(int64_t utime);
  // The nodes of the session that made the map's origin leave the partition (no step registers
  // to them, no new place is refused for them) and registrations to them are refused; the next
  // node is a new origin. One line, counted (sessions_quarantined, nodes_quarantined).
  void quarantineOrigin();
  // The step's wall and CPU time since t0/c0, added to the step's cost so far.
  void addStepCost(SteadyClock::time_point t0, double c0);

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
  // A registration to a restored node while resumedUnconfirmed().
  std::optional<int64_t> confirmResumed(const InFlight& f, int64_t b,
                                        const core::UncertainPose& b_T_q,
                                        const core::UncertainPose& q_T_now, bool* registered);
  // Whether `node` opens a new loop pair without the information test: below
  // closure_partners and new (MapperOptions::closure_partner_sessions).
  bool takesFreePair(int64_t node) const;
  // The robot placed on b by b_T_q (q_T_now since the keyframe): b active, no constraint.
  void relocalizeOn(int64_t b, const core::UncertainPose& b_T_q,
                    const core::UncertainPose& q_T_now);

  // Relocalisation and gate recovery (mapper_relocalization.cpp). Whether b_T_q confirms the
  // candidate placement; if not it becomes the candidate, and *check is the node to check it
  // against on the same keyframe (linkedNeighbour), if any.
  bool confirmsCandidate(const InFlight& f, int64_t b, const core::UncertainPose& b_T_q,
                         std::optional<int64_t>* check);
  // While lost with a candidate placement: the node to check it against (step), if any.
  std::optional<int64_t> relocalizationCheck(int64_t keyframe_utime);
  // A node the map links to `node` (a constraint between them) whose view overlaps the
  // placement world_T_body (within overlap_heading_sectors of its heading), the nearest.
  std::optional<int64_t> linkedNeighbour(int64_t node, const core::SE3d& world_T_body) const;
  // Whether the registration b_T_q of the keyframe agrees, chained by odometry, with an
  // earlier one (candidate) on where the robot is.
  bool confirmsRelocalization(int64_t b, const core::UncertainPose& b_T_q, int64_t keyframe_utime,
                              const std::optional<PlacementCandidate>& candidate);
  // A registration the map gate rejects: true when it confirms the previous rejected one
  // (then both were right and the map or Δ was wrong) and its jump_m is a drift odometry could
  // have made (GateRecovery); otherwise it becomes the candidate.
  bool confirmsRejected(int64_t b, const core::UncertainPose& b_T_q, int64_t keyframe_utime,
                        double jump_m);
  // How far apart the map puts the keyframe q through a (Δ = a_T_q) and through b (b_T_q).
  double jumpM(int64_t a, const core::UncertainPose& a_T_q, int64_t b,
               const core::UncertainPose& b_T_q) const;
  // Gaps odometry bridged so far (tracker counts and rides).
  int64_t bridges() const;
  // The map gate's test of a_T_b (map_gate.h), its time counted.
  bool consistentWithMap(int64_t a, int64_t b, const core::UncertainPose& a_T_b,
                         double* information = nullptr);

  // The graph (mapper_graph.cpp): nodes, factors and constraints, gathered for the solver's
  // next update (flushSolver: the step's end; a full-graph step's node before its request too).
  int64_t addNode(int64_t keyframe_utime, const core::UncertainPose& active_T_node);
  // The IMU's roll and pitch at the keyframe, when a trusted ATTITUDE is at most 1 s older.
  std::optional<NodeAttitude> attitudeAt(int64_t keyframe_utime) const;
  // The partial factor of IMU roll and pitch on a node (false: a covariance it cannot use).
  bool addAttitudeFactor(int64_t id, const NodeAttitude& attitude);
  void addOriginPrior(int64_t id, const core::SE3d& world_T_node);
  // vetted: a loop closure the map gate has tested against the map (no robust kernel).
  void addConstraint(int64_t from, int64_t to, const core::UncertainPose& from_T_to,
                     ConstraintKind kind, int64_t utime, bool vetted = false);
  // The step's changes to the solver (solver_schedule.h), and the partition index after them.
  void flushSolver();
  void recordFlush(const SolverSchedule::Flush& flush);
  // The node of the place world_T_body is in (partition_index.h), else the node of an earlier
  // session's footprint that covers it (view_footprints.h).
  std::optional<int64_t> nodeAt(const core::SE3d& world_T_body, int floor,
                                int64_t newest_allowed) const;
  // The place of a step's registration filed as its node's, when no node serves it.
  void addFootprint(const Footprint& view, int64_t keyframe_utime);
  ViewFootprints::NodePoses poses() const;

  // A stored map read back (mapper_restore.cpp): its nodes and their factors, its
  // constraints, and the tracking a warm restart resumes.
  Status restoreNodes(const MapSnapshot& map, const std::map<int, double>& floors,
                      int* max_session);
  Status restoreEdges(const MapSnapshot& map);
  // An origin prior on the first node of every part of the stored map not tied to node 0.
  void anchorComponents(const MapSnapshot& map);
  void resume(const WarmRestart::Resume& r);

  // Algorithm 1's state: the options, the session, the graph (partition index, nodes,
  // constraints, solver), the tracked Δ against the active node, the step in flight.
  MapperOptions o_;
  int session_;
  int first_session_;
  PartitionIndex partition_;
  ViewFootprints footprints_;
  ConstraintSet constraints_;
  SolverSchedule schedule_;
  MapGate map_gate_;
  std::vector<MapperNode> nodes_;
  int64_t active_ = -1;
  bool relocalize_ = false;  // after a loop closure: the next registration to b replaces Δ
  bool lost_ = false;        // a new session that no global registration has placed yet
  // Whether a registration ever confirmed a node of the map (or the map was restored), and the
  // session whose first node is the current origin; sessions quarantined (startSession).
  bool map_confirmed_ = false;
  int origin_session_ = -1;
  std::vector<bool> quarantined_;  // by node id
  bool gate_rejected_ = false;     // the step in flight had a registration the gate rejected
  int64_t last_step_utime_ = -1;
  int64_t last_vo_utime_ = -1;
  int64_t session_start_utime_ = -1;  // utime of the message that started the session
  std::optional<InFlight> in_flight_;
  // While lost (or resumed unconfirmed): the last registration to the map, waiting for a
  // second one that agrees.
  std::optional<PlacementCandidate> relocalization_candidate_;
  GateRecovery recovery_;
  FloorState floors_;
  WarmRestart warm_;
  std::optional<attitude_t> attitude_;  // the last trusted ATTITUDE (node roll/pitch factors)
  int64_t last_attitude_utime_ = -1;
  double step_cost_s_ = 0.0;  // wall time of the step in progress so far
  double step_cpu_s_ = 0.0;   // ... and CPU time of the mapper's thread
  // Outputs.
  std::vector<node_added_t> nodes_added_;
  std::vector<std::string> notes_;
  std::vector<StepPose> step_poses_;
  MapperStats stats_;
};

}  // namespace evermap::mapper
