#pragma once
// Localization against a stored map (docs/localization.md): Algorithm 1's tracking and
// registrations without its growth. The map is what a map store held when load() read it
// (node poses fixed, nothing solved); the localizer adds no node, no factor, no fold, and
// writes nothing.
//
// The pose: world_T_body = x_a ⊕ Δ, x_a a stored node's pose and Δ tracked from VO, wheels and
// the gyro by the mapper's Tracker, its covariance Δ's plus the drift of dead reckoning
// (below; right tangent, the body's frame; the stored nodes count as known). At a VO keyframe, at
// most once every step_interval_s, a registration request goes to loopclose-proc:
//   - placed and localized: MODE_NODE to the node of the place the pose is in (the mapper's
//     partition index over the stored poses), then MODE_GLOBAL on the floor if that fails;
//   - not localized: MODE_GLOBAL on every floor, or MODE_NODE where a candidate placement
//     predicts the robot is (the mapper's relocalisation check).
// An answer b_T_q, while localized, is tested by the map gate against the prediction
// x_b⁻¹ x_a Δ (its covariance Δ's plus the drift): agreeing, the two are fused and b becomes the
// node Δ is tracked against; refused, it is counted (refused_gate) and not applied alone (below).
// Not localized, it becomes a candidate, and a second registration that agrees with it through
// odometry (the mapper's chainPlacements, the map's relative pose of the two nodes given
// localize.map_sigma_*) places the robot: localized.
//
// Leaving the mapped area: with no registration applied, Δ is dead reckoning and its
// covariance grows with every increment, and with the drift of the distance travelled since
// the last registration applied (localize.drift_per_m, drift_deg_per_m). The pose is still
// given (localized = false) once the larger x-y standard deviation exceeds
// localize.max_sigma_m or the yaw's localize.max_sigma_deg; from then on only two agreeing
// registrations localize it again.
//
// An elevator ride (FLOOR vertical motion, or ride start, to the ride's end) takes no step; at
// its end the ride's height change moves the pose and the floor is the stored one at that
// height (none within floor_match_m: unknown, and not localized). During the ride the pose is
// not localized; vertical motion that ends still (no ride) changes nothing.
//
// Once placed, a registration to a node more than floor_match_m above or below the tracked
// height is refused (refused_floor): the floors of a building look alike, and a robot that rode
// to a floor the map does not hold must not be placed on one it does.
//
// Drift and aliasing (gate_recovery.h, the mapper's rules): while localized, two refused
// registrations that agree with each other re-track the pose (gate_recoveries) when no
// registration has confirmed it for recovery_quiet_s (or odometry bridged a gap), and only
// by a jump odometry could have drifted since the last registration applied (recovery_slack_m
// + recovery_drift_fraction x the distance); a robot placed once and lost again is placed anew
// only within that too (placements_too_far): repeated texture makes false matches that
// agree with each other one texture period away.

#include <algorithm>
#include <cstdint>
#include <map>
#include <optional>
#include <vector>

#include <evermap/attitude_t.hpp>
#include <evermap/floor_t.hpp>
#include <evermap/register_request_t.hpp>
#include <evermap/register_result_t.hpp>

#include "mapper-proc/gate_recovery.h"
#include "mapper-proc/map_gate.h"
#include "mapper-proc/map_inputs.h"
#include "mapper-proc/map_node.h"
#include "mapper-proc/mapper_options.h"
#include "mapper-proc/partition_index.h"
#include "mapper-proc/tracker.h"

namespace evermap::mapper {

struct LocalizerStats {
  int64_t steps = 0;
  int64_t requests_node = 0;
  int64_t requests_global = 0;
  int64_t registrations_ok = 0;
  int64_t placements = 0;          // not localized -> localized (two agreeing registrations)
  int64_t corrections = 0;         // registrations applied while localized
  int64_t refused_gate = 0;        // ... refused by the map gate: counted, never applied alone
  int64_t gate_recoveries = 0;     // two refused that agree: the pose had drifted, re-tracked
  int64_t recoveries_too_far = 0;  // ... not: a jump farther than odometry could drift
  int64_t placements_too_far = 0;  // a placed robot's new placement farther than that
  int64_t refused_floor = 0;       // a node of another floor than the current one
  int64_t disagreements = 0;       // a candidate and a registration that did not agree
  int64_t unlocalized = 0;         // localized -> not (the bounds above)
  int64_t timeouts = 0;
  int64_t dropped = 0;  // malformed messages, unknown nodes, answers to no request
  int64_t rides = 0;
  int64_t vertical_alarms = 0;  // EVENT_VERTICAL_MOTION: not localized until still or the end
};

class Localizer : public MapConsumer {
 public:
  explicit Localizer(const MapperOptions& options);

  // The stored map (a map store read once, read-only): its nodes, poses and floors. Errors:
  // an empty map, ids that are not 0..n-1 in order, a pose that is not finite.
  Status load(const MapSnapshot& map);
  // Inputs, as the mapper's (map_inputs.h).
  Status onVo(const vo_delta_t& msg) override;
  Status onWheel(const wheel_odom_t& msg) override;
  Status onAttitude(const attitude_t& msg) override;
  Status onFloor(const floor_t& msg) override;
  Status onRegisterResult(const register_result_t& msg) override;
  // Requests (takeRequests(), map_inputs.h) are made in the session after the stored map's.

  // Whether the robot was ever placed on the map (pose() means something), and whether it is
  // localized now (placed, within the bounds above, not riding an elevator: its height is
  // unobserved until the ride ends).
  bool placed() const { return active_ >= 0; }
  bool localized() const { return localized_ && !in_ride_; }
  // world_T_body now, its covariance Δ's with the drift since the last registration applied
  // (localize.drift_*); meaningless before placed().
  core::UncertainPose pose() const;
  int floor() const { return floor_; }
  // Metres travelled (the tracker's odometer) since the last registration applied.
  double deadReckoningM() const { return std::max(tracker_.odometerM() - odometer_at_fix_m_, 0.0); }
  int64_t activeNode() const { return active_; }
  int session() const { return session_; }
  const std::vector<MapperNode>& nodes() const { return nodes_; }
  const core::SE3d& nodePose(int64_t id) const { return poses_[static_cast<size_t>(id)]; }
  const LocalizerStats& stats() const { return stats_; }

 private:
  struct InFlight {
    int64_t request_id = 0;
    int64_t keyframe_utime = 0;
    int8_t mode = 0;
    int64_t active = -1;
    core::UncertainPose delta_at_keyframe;  // active_T_keyframe
    bool localized = false;                 // at the request
  };
  // A keyframe step, when one is due (at a keyframe VO chains from, not during a ride).
  void stepAt(int64_t keyframe_utime);
  void takeHeldStep(int64_t now_utime);
  void sendRequest(int8_t mode, int64_t target);
  void checkTimeout(int64_t utime);
  // The node the step's MODE_NODE request names, if any (localized: the place the pose is
  // in; not: a candidate's check).
  std::optional<int64_t> stepTarget(int64_t keyframe_utime);
  // What a registration of the keyframe does (localizer_registration.cpp).
  void correct(const InFlight& f, int64_t b, const core::UncertainPose& b_T_q,
               const core::UncertainPose& q_T_now);
  void place(const InFlight& f, int64_t b, const core::UncertainPose& b_T_q,
             const core::UncertainPose& q_T_now);
  // A node the robot cannot be at: another floor than the current one while localized; once
  // placed, a node more than floor_match_m above or below the tracked height.
  bool otherFloor(int64_t b) const;
  // Whether b_T_q and the placement c agree through odometry and the stored map.
  bool agrees(const PlacementCandidate& c, int64_t b, const core::UncertainPose& b_T_q,
              int64_t keyframe_utime);
  // A registration the gate refused while localized: with an earlier refused one that agrees
  // with it, the pose is re-tracked from it (the gate recovery, gate_recovery.h); true then.
  bool recover(const InFlight& f, int64_t b, const core::UncertainPose& b_T_q,
               const core::UncertainPose& q_T_now);
  // How far the placement b_T_q puts the keyframe from where Δ had it (m).
  double jumpM(const InFlight& f, int64_t b, const core::UncertainPose& b_T_q) const;
  // Δ := b_T_now, b the node tracked against, from the registration of the keyframe at
  // keyframe_utime; the dead-reckoning count restarts.
  void trackFrom(int64_t b, const core::UncertainPose& b_T_now, int64_t keyframe_utime);
  // Δ, its covariance grown by the drift of the distance since the last registration applied.
  core::UncertainPose deadReckoned() const;
  // The bounds of the header: localized_ follows them.
  void updateLocalized();
  // The stored floor at height_m (within floor_match_m), or -1.
  int floorAt(double height_m) const;

  MapperOptions o_;
  PartitionIndex partition_;
  MapGate map_gate_;
  GateRecovery recovery_;
  std::vector<MapperNode> nodes_;
  std::vector<core::SE3d> poses_;
  std::map<int, double> floors_;  // the stored table: floor -> height
  int session_ = 0;
  int floor_ = -1;               // -1: unknown (before placed, after a ride to no stored floor)
  bool in_ride_ = false;         // from vertical motion (or a ride's start) to the ride's end
  bool ride_confirmed_ = false;  // ... the ride's start came
  double ride_start_height_m_ = 0.0;  // FLOOR's at the ride's start ...
  double ride_start_z_m_ = 0.0;       // ... and the pose's
  int64_t active_ = -1;
  bool localized_ = false;
  double odometer_at_fix_m_ = 0.0;  // tracker odometer at the last registration applied
  std::optional<PlacementCandidate> candidate_;
  std::optional<InFlight> in_flight_;
  int64_t last_step_utime_ = -1;
  int64_t last_attitude_utime_ = -1;
  LocalizerStats stats_;
};

}  // namespace evermap::mapper
