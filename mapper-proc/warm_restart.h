#pragma once
// The warm restart (docs/mapper.md, "Restarts"): how a mapper restored from a store that holds
// its tracking state (TrackingState) starts, decided at the first VO_DELTA after restore().
//
// If that frame comes at most warm_restart_max_gap_s after the state and no FLOOR message
// newer than the state announced a ride or a session, tracking resumes from the state's node
// in its session and floor. The motion over the gap comes from the odometry when it can
// bridge it (VO's odometry frame of the same epoch, else the wheels'; the frame may wait up to
// warm_restart_wheel_wait_s for a wheel pose to bridge with): then tracking goes on as if
// nothing had been lost. Otherwise Δ's covariance grows by the gap (warm_restart_speed_m_s,
// warm_restart_turn_rad_s) and the placement stays *unconfirmed* until two agreeing
// registrations to the restored map confirm it (the mapper's registration protocol, which
// consults unconfirmed() and restoredNode()). Near an elevator, a gap a ride fits in is not
// resumed (warm_restart_elevator_radius_m): the restart is lost, as it is without a state.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <evermap/floor_t.hpp>
#include <evermap/vo_delta_t.hpp>

#include "mapper-proc/constraint_set.h"
#include "mapper-proc/map_node.h"
#include "mapper-proc/mapper_options.h"
#include "mapper-proc/mapper_stats.h"
#include "mapper-proc/solver_schedule.h"
#include "mapper-proc/tracker.h"

namespace evermap::mapper {

// The restored map as the restart decision reads it: its nodes, their constraints and poses.
struct RestoredMap {
  const std::vector<MapperNode>& nodes;
  const ConstraintSet& constraints;
  const SolverSchedule& schedule;
};

class WarmRestart {
 public:
  explicit WarmRestart(const MapperOptions& options) : o_(options) {}

  // At restore() of a map of `nodes` nodes whose newest was made at newest_node_utime: the
  // stored state is used when it names a stored node and is not older than the newest node
  // (the state is written in every transaction that writes nodes); else the start is lost.
  void arm(const std::optional<TrackingState>& stored, int64_t nodes, int64_t newest_node_utime,
           MapperStats& stats);
  // Whether the decision is still to be taken (at the next VO_DELTA).
  bool pending() const { return saved_.has_value(); }
  // A FLOOR message newer than the state: a ride or a session announced since, so the state's
  // floor or session is no longer the robot's; the start is lost.
  void onFloor(const floor_t& msg, MapperStats& stats);
  // Whether the VO frame msg is set aside: the saved state holds a wheel pose, VO cannot
  // bridge, no wheel pose at msg's time has arrived yet, and the wait is not over.
  bool waitForWheels(const vo_delta_t& msg, const Tracker& tracker);

  // Where tracking resumes: the saved state and Δ over the gap (bridged or inflated).
  struct Resume {
    TrackingState state;
    core::UncertainPose active_T_body;
  };
  // The decision at the first VO_DELTA msg (the tracker has taken it): a resume, or empty (a
  // lost start).
  std::optional<Resume> decide(const vo_delta_t& msg, const Tracker& tracker,
                               const RestoredMap& map, MapperStats& stats);

  // A resumed placement no registration has confirmed yet (not bridged), until confirmed().
  bool unconfirmed() const { return unconfirmed_; }
  void confirmed() { unconfirmed_ = false; }
  // A node of the restored map (not one made since the restart).
  bool restoredNode(int64_t id) const { return id < first_new_node_; }
  // The gap between the saved state and the first VO_DELTA, seconds, once decided (negative:
  // no saved state usable); how the restart was decided, for the log.
  std::optional<double> gapS() const { return gap_s_; }
  const std::string& note() const { return note_; }

 private:
  // The motion over the gap from VO's odometry frame, from the state's VO frame to msg's
  // (saved_T_now, body frames), when it may cross it; else empty, and `why` says why not.
  std::optional<core::UncertainPose> odometryBridge(const TrackingState& s, const vo_delta_t& msg,
                                                    const Tracker& tracker, std::string& why) const;
  // The same from the wheels' odometry frame, to the first VO_DELTA's time `utime`.
  std::optional<core::UncertainPose> wheelBridge(const TrackingState& s, int64_t utime,
                                                 const Tracker& tracker, std::string& why) const;
  // The bridge over the gap (VO's, else the wheels'), with note_ saying which or why none.
  std::optional<core::UncertainPose> bridge(const TrackingState& s, const vo_delta_t& msg,
                                            const Tracker& tracker, bool* by_wheels);
  // The node at an end of a ride (an odometry constraint between floors) closest in x-y to
  // world_T_body within warm_restart_elevator_radius_m, and its distance; empty if none.
  std::optional<std::pair<int64_t, double>> elevatorNear(const core::SE3d& world_T_body,
                                                         const RestoredMap& map) const;
  // Whether a ride may lie in a gap of gap_s near an elevator (then note_ says where).
  bool rideMayLieInGap(const TrackingState& s, double gap_s,
                       const std::optional<core::UncertainPose>& bridge, const RestoredMap& map);

  MapperOptions o_;
  std::optional<TrackingState> saved_;  // arm()'s, until the decision
  bool unconfirmed_ = false;
  std::optional<double> gap_s_;
  int64_t first_vo_utime_ = -1;  // the first VO_DELTA after the restart (waitForWheels)
  std::string note_;
  int64_t first_new_node_ = 0;  // nodes from this id on were made after the restart
};

}  // namespace evermap::mapper
