#include "mapper-proc/warm_restart.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <sstream>

#include "core/common/clocks.h"
#include "core/messages/odometry_frame.h"

namespace evermap::mapper {

namespace {

// No bridge, and `why` (the parts streamed) says why not.
template <typename... Parts>
std::optional<core::UncertainPose> noBridge(std::string& why, const Parts&... parts) {
  std::ostringstream w;
  (w << ... << parts);
  why = w.str();
  return std::nullopt;
}

double secondsBetween(int64_t from_utime, int64_t to_utime) {
  return 1e-6 * static_cast<double>(to_utime - from_utime);
}

}  // namespace

void WarmRestart::arm(const std::optional<TrackingState>& stored, int64_t nodes,
                      int64_t newest_node_utime, MapperStats& stats) {
  first_new_node_ = nodes;
  saved_.reset();
  if (stored && stored->active_node >= 0 && stored->active_node < nodes &&
      stored->utime >= newest_node_utime) {
    saved_ = stored;
    first_vo_utime_ = -1;
    return;
  }
  ++stats.lost_restarts;
  gap_s_ = -1.0;
  note_ = !stored ? "no tracking state stored (the mapper was lost, or an older store)"
                  : "the stored tracking state is older than the newest node or names none";
}

void WarmRestart::onFloor(const floor_t& msg, MapperStats& stats) {
  // Older FLOOR messages (a log replayed from its start) are what the state already holds.
  if (!saved_ || msg.utime <= saved_->utime) return;
  saved_.reset();
  ++stats.lost_restarts;
  gap_s_ = -1.0;
  note_ = msg.event == floor_t::EVENT_RIDE_START || msg.event == floor_t::EVENT_RIDE_END
              ? "a ride announced after the saved tracking state"
              : "a session announced after the saved tracking state";
}

std::optional<core::UncertainPose> WarmRestart::odometryBridge(const TrackingState& s,
                                                               const vo_delta_t& msg,
                                                               const Tracker& tracker,
                                                               std::string& why) const {
  if (!o_.warm_restart_bridge) return noBridge(why, "mapper.warm_restart_bridge is off");
  if (!s.odometry) return noBridge(why, "the saved state holds no odometry pose");
  std::string malformed;
  const auto now = messages::odometryPose(msg, &malformed);
  if (!now) return noBridge(why, "the first VO_DELTA: ", malformed);
  const messages::OdometryPose& saved = s.odometry->pose;
  if (now->epoch != saved.epoch)
    return noBridge(why, "odometry epoch ", saved.epoch, " then, ", now->epoch, " now");
  const double gap_s = secondsBetween(saved.utime, now->utime);
  if (gap_s > o_.warm_restart_bridge_max_gap_s)
    return noBridge(why, gap_s, " s > mapper.warm_restart_bridge_max_gap_s");
  const auto cam = messages::odometryBetween(saved, s.odometry->own_covariance, *now);
  if (!cam) return noBridge(why, cam.error().message);
  // saved_T_now of the body; the odometry's frame is the camera's.
  const core::UncertainPose body = tracker.toBody(cam->mean, cam->covariance);
  if (const std::string implausible =
          tracker.implausibleMotion(body.mean.translation().norm(),
                                    core::rotationAngle(body.mean.so3()), saved.utime, now->utime);
      !implausible.empty())
    return noBridge(why, "implausible: ", implausible);
  // The body is level (to the IMU's accuracy): its z is the world's vertical.
  if (std::abs(body.mean.translation().z()) > o_.floor_match_m)
    return noBridge(why, "a vertical motion of ", body.mean.translation().z(), " m (a ride?)");
  return body;
}

std::optional<core::UncertainPose> WarmRestart::wheelBridge(const TrackingState& s, int64_t utime,
                                                            const Tracker& tracker,
                                                            std::string& why) const {
  if (!o_.warm_restart_bridge) return noBridge(why, "mapper.warm_restart_bridge is off");
  if (!s.wheel) return noBridge(why, "the saved state holds no wheel odometry pose");
  const auto now = tracker.wheelOdometryAt(utime);
  if (!now) return noBridge(why, "no wheel odometry pose at ", utime);
  if (now->epoch != s.wheel->epoch)
    return noBridge(why, "wheel odometry epoch ", s.wheel->epoch, " then, ", now->epoch, " now");
  const double gap_s = secondsBetween(s.wheel->utime, now->utime);
  if (gap_s > o_.warm_restart_bridge_max_gap_s)
    return noBridge(why, gap_s, " s > mapper.warm_restart_bridge_max_gap_s");
  const auto d = messages::wheelOdometryBetween(*s.wheel, *now);
  if (!d) return noBridge(why, d.error().message);
  // The SSC covariance is over (x, y) in the start frame; the right tangent's translation is
  // in the end frame: rotated by the motion's θ.
  Eigen::Matrix3d to_right = Eigen::Matrix3d::Identity();
  to_right.topLeftCorner<2, 2>() = d->a_T_b.rotationMatrix().transpose();
  const core::UncertainPose body =
      tracker.planarMotion(d->a_T_b.vector(), to_right * d->covariance * to_right.transpose());
  const double distance_m = d->a_T_b.translation().norm();
  const double angle_rad = std::abs(d->a_T_b.theta());
  if (const std::string implausible =
          tracker.implausibleMotion(distance_m, angle_rad, s.wheel->utime, now->utime);
      !implausible.empty())
    return noBridge(why, "implausible: ", implausible);
  return body;
}

bool WarmRestart::waitForWheels(const vo_delta_t& msg, const Tracker& tracker) {
  if (o_.warm_restart_wheel_wait_s <= 0.0 || !saved_->wheel || saved_->in_elevator ||
      tracker.wheelOdometryAt(msg.utime))
    return false;
  // A gap no bridge crosses (a new session's first frame, hours or days after the state):
  // nothing to wait for, and the frames set aside would be the session's first keyframe,
  // where the robot stands where it stood before (the relocalisation's best chance).
  if (secondsBetween(saved_->utime, msg.utime) > o_.warm_restart_bridge_max_gap_s) return false;
  if (first_vo_utime_ < 0) first_vo_utime_ = msg.utime;
  if (msg.utime - first_vo_utime_ > micros(o_.warm_restart_wheel_wait_s)) return false;
  std::string why_not;
  return !odometryBridge(*saved_, msg, tracker, why_not);
}

std::optional<std::pair<int64_t, double>> WarmRestart::elevatorNear(const core::SE3d& world_T_body,
                                                                    const RestoredMap& map) const {
  std::optional<std::pair<int64_t, double>> best;
  if (o_.warm_restart_elevator_radius_m <= 0.0) return best;
  const auto n = static_cast<int64_t>(map.nodes.size());
  for (const Constraint& c : map.constraints.all()) {
    if (c.kind != ConstraintKind::kOdometry || c.from < 0 || c.to < 0 || c.from >= n || c.to >= n)
      continue;
    if (map.nodes[static_cast<size_t>(c.from)].floor == map.nodes[static_cast<size_t>(c.to)].floor)
      continue;
    for (const int64_t id : {c.from, c.to}) {
      const double d =
          (map.schedule.pose(id).translation() - world_T_body.translation()).head<2>().norm();
      if (d <= o_.warm_restart_elevator_radius_m && (!best || d < best->second))
        best = std::pair{id, d};
    }
  }
  return best;
}

std::optional<core::UncertainPose> WarmRestart::bridge(const TrackingState& s,
                                                       const vo_delta_t& msg,
                                                       const Tracker& tracker, bool* by_wheels) {
  // With the odometry frame the motion over the gap is known (a measurement, as Δ's own
  // increments): tracking goes on.
  std::string vo_why, wheel_why;
  std::optional<core::UncertainPose> bridged = odometryBridge(s, msg, tracker, vo_why);
  *by_wheels = false;
  if (!bridged) {
    bridged = wheelBridge(s, msg.utime, tracker, wheel_why);
    *by_wheels = bridged.has_value();
  }
  std::ostringstream note;
  if (!bridged) {
    note << "not bridged: " << vo_why << "; wheels: " << wheel_why;
  } else {
    const int64_t from_utime = *by_wheels ? s.wheel->utime : s.odometry->pose.utime;
    note << (*by_wheels ? "bridged by wheel odometry over " : "bridged by odometry over ")
         << secondsBetween(from_utime, msg.utime) << " s: " << bridged->mean.translation().norm()
         << " m, " << core::rotationAngle(bridged->mean.so3()) << " rad";
    if (*by_wheels) note << " (VO not bridged: " << vo_why << ")";
  }
  note_ = note.str();
  return bridged;
}

bool WarmRestart::rideMayLieInGap(const TrackingState& s, double gap_s,
                                  const std::optional<core::UncertainPose>& bridged,
                                  const RestoredMap& map) {
  // Near an elevator, a gap long enough to ride may hold a ride neither bridge sees: the
  // floor is unknown, so the restart is lost (global searches on every floor), not inflated.
  // The note keeps what the bridge said (bridged by what, or why not).
  if (gap_s < o_.warm_restart_ride_min_s || s.active_node < 0 ||
      s.active_node >= static_cast<int64_t>(map.nodes.size()))
    return false;
  const core::SE3d saved = map.schedule.pose(s.active_node) * s.active_T_body.mean;
  auto near = elevatorNear(saved, map);
  if (!near && bridged) near = elevatorNear(saved * bridged->mean, map);
  if (!near) return false;
  std::ostringstream elevator;
  elevator << near->second << " m from the elevator at node " << near->first << " over " << gap_s
           << " s: a ride may lie in the gap (" << note_ << ")";
  note_ = elevator.str();
  return true;
}

std::optional<WarmRestart::Resume> WarmRestart::decide(const vo_delta_t& msg,
                                                       const Tracker& tracker,
                                                       const RestoredMap& map, MapperStats& stats) {
  const TrackingState s = *saved_;
  saved_.reset();
  const double gap_s = secondsBetween(s.utime, msg.utime);
  gap_s_ = gap_s;
  if (s.in_elevator || !(gap_s >= 0.0) || o_.full_graph || o_.warm_restart_max_gap_s <= 0.0) {
    note_ = s.in_elevator ? "saved in the elevator cab"
                          : "no warm restart (options, or a state from the future)";
    ++stats.lost_restarts;
    return std::nullopt;
  }
  bool by_wheels = false;
  const std::optional<core::UncertainPose> bridged = bridge(s, msg, tracker, &by_wheels);
  if (rideMayLieInGap(s, gap_s, bridged, map)) {
    ++stats.lost_restarts;
    ++stats.warm_elevator_refusals;
    return std::nullopt;
  }
  if (!bridged && gap_s > o_.warm_restart_max_gap_s) {
    ++stats.lost_restarts;
    return std::nullopt;
  }
  // Where the robot was at s.utime, in its session, on its floor, moved by the bridge; or,
  // with nothing that tracked it over the gap, its covariance grown by what it may have
  // driven and turned meanwhile (linear in the gap: a bounded speed); height, roll and pitch
  // stay (a floor, a level body).
  Resume r{s, s.active_T_body};
  if (bridged) {
    r.active_T_body = core::compound(r.active_T_body, *bridged);
  } else {
    const double sigma_m = o_.warm_restart_speed_m_s * gap_s;
    const double sigma_rad = std::min(o_.warm_restart_turn_rad_s * gap_s, std::numbers::pi);
    core::Vec6 grow;
    grow << sigma_m * sigma_m, sigma_m * sigma_m, 0.0025 * gap_s, 1e-4 * gap_s, 1e-4 * gap_s,
        sigma_rad * sigma_rad;
    r.active_T_body.covariance += grow.asDiagonal();
  }
  // A bridged pose needs no confirmation: the odometry between the two frames is the chain of
  // VO motions the tracker would have compounded into Δ had it received them, with their
  // covariance, so registrations are tested against it by the map gate as against any Δ.
  // The held pose is off by what the robot drove in the gap: confirmed before any closure.
  unconfirmed_ = !bridged;
  ++stats.warm_restarts;
  if (bridged) ++stats.warm_bridged;
  if (by_wheels) ++stats.warm_bridged_by_wheels;
  return r;
}

}  // namespace evermap::mapper
