// Localization against a stored map (localizer.h): the map loaded, the inputs tracked, the
// keyframe steps and their requests, and when the pose counts as localized.

#include "mapper-proc/localizer.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <utility>

#include "core/common/clocks.h"

namespace evermap::mapper {

Localizer::Localizer(const MapperOptions& options)
    : MapConsumer(options.tracker),
      o_(options),
      partition_({options.cell_size_m, options.heading_bins, options.overlap_radius_cells,
                  options.overlap_heading_sectors, options.cell_refresh_per_step}),
      map_gate_(options.map_gate),
      recovery_(options) {}

Status Localizer::load(const MapSnapshot& map) {
  if (map.nodes.empty()) return Error("the map holds no node: nothing to localize against");
  int max_session = 0;
  for (size_t i = 0; i < map.nodes.size(); ++i) {
    const StoredNode& s = map.nodes[i];
    if (s.node.id != static_cast<int64_t>(i))
      return makeError("node ids are not 0..n-1 in order (node ", s.node.id, " at row ", i, ")");
    const core::SE3d pose = s.world_T_body;
    if (!pose.translation().allFinite() || !pose.quaternion().coeffs().allFinite())
      return makeError("node ", s.node.id, ": pose not finite");
    nodes_.push_back(s.node);
    poses_.push_back(pose);
    partition_.file(s.node.id, partition_.cellOf(pose, s.node.floor));
    max_session = std::max(max_session, s.node.session);
  }
  for (const auto& [floor, height_m] : map.floors) floors_[floor] = height_m;
  for (const auto& [session, start_utime] : map.sessions)
    max_session = std::max(max_session, session);
  session_ = max_session + 1;
  return Ok{};
}

Status Localizer::onVo(const vo_delta_t& msg) {
  takeHeldStep(msg.utime);
  if (Status s = tracker_.addVo(msg); !s) {
    ++stats_.dropped;
    return s;
  }
  checkTimeout(msg.utime);
  if (msg.keyframe_changed) stepAt(msg.utime);
  updateLocalized();
  return Ok{};
}

Status Localizer::onWheel(const wheel_odom_t& msg) {
  if (tracker_.heldStepDue(msg.utime)) takeHeldStep(msg.utime);
  const Status s = tracker_.addWheel(msg);
  if (!s) ++stats_.dropped;
  updateLocalized();
  return s;
}

Status Localizer::onAttitude(const attitude_t& msg) {
  if ((msg.heading_valid && !std::isfinite(msg.heading_rad)) || msg.utime <= last_attitude_utime_) {
    ++stats_.dropped;
    return makeError("ATTITUDE ", msg.utime, ": not finite or out of order");
  }
  last_attitude_utime_ = msg.utime;
  const Status s = tracker_.addHeading(msg);
  if (tracker_.heldStepCovered()) takeHeldStep(msg.utime);
  return s;
}

Status Localizer::onFloor(const floor_t& msg) {
  takeHeldStep(msg.utime);
  if (!std::isfinite(msg.height_m)) {
    ++stats_.dropped;
    return makeError("FLOOR ", msg.utime, ": height not finite");
  }
  if (msg.event == floor_t::EVENT_VERTICAL_MOTION || msg.event == floor_t::EVENT_RIDE_START) {
    // The first sign of a ride (or its confirmed start, when no sign came before it): the
    // height is unobserved from here on.
    if (msg.event == floor_t::EVENT_VERTICAL_MOTION) ++stats_.vertical_alarms;
    if (!in_ride_) {
      ride_start_height_m_ = msg.height_m;
      ride_start_z_m_ = pose().mean.translation().z();
    }
    in_ride_ = true;
    ride_confirmed_ = ride_confirmed_ || msg.event == floor_t::EVENT_RIDE_START;
    return Ok{};
  }
  if (msg.event == floor_t::EVENT_VERTICAL_STILL && in_ride_ && !ride_confirmed_) {
    in_ride_ = false;  // no ride followed: the height never changed
    return Ok{};
  }
  if (msg.event != floor_t::EVENT_RIDE_END || !in_ride_) return Ok{};
  // The ride's height change (elevator-proc's heights are its own, their difference is not),
  // as far as odometry has not seen it already; the floor is the stored one at that height.
  in_ride_ = false;
  ride_confirmed_ = false;
  ++stats_.rides;
  if (!placed()) return Ok{};
  const double z = ride_start_z_m_ + (msg.height_m - ride_start_height_m_);
  tracker_.addHeight(z - pose().mean.translation().z(), std::max(msg.height_sigma_m, 0.01));
  floor_ = floorAt(z);
  updateLocalized();
  return Ok{};
}

core::UncertainPose Localizer::pose() const {
  core::UncertainPose p = deadReckoned();
  if (active_ >= 0) p.mean = nodePose(active_) * p.mean;
  return p;
}

core::UncertainPose Localizer::deadReckoned() const {
  core::UncertainPose d = tracker_.delta();
  const double xy = o_.localize.drift_per_m * deadReckoningM();
  const double yaw = o_.localize.drift_deg_per_m * deadReckoningM() * std::numbers::pi / 180.0;
  d.covariance(0, 0) += xy * xy;
  d.covariance(1, 1) += xy * xy;
  d.covariance(5, 5) += yaw * yaw;
  return d;
}

int Localizer::floorAt(double height_m) const {
  int best = -1;
  double best_m = o_.floor_match_m;
  for (const auto& [floor, h] : floors_) {
    if (std::abs(h - height_m) <= best_m) {
      best_m = std::abs(h - height_m);
      best = floor;
    }
  }
  return best;
}

void Localizer::updateLocalized() {
  if (!localized_) return;
  const core::Mat6 c = deadReckoned().covariance;
  const double sigma_m = std::sqrt(std::max(c(0, 0), c(1, 1)));
  const double sigma_deg = std::sqrt(std::max(c(5, 5), 0.0)) * 180.0 / std::numbers::pi;
  if (sigma_m > o_.localize.max_sigma_m || sigma_deg > o_.localize.max_sigma_deg || floor_ < 0) {
    localized_ = false;
    candidate_.reset();
    ++stats_.unlocalized;
  }
}

void Localizer::takeHeldStep(int64_t now_utime) {
  const auto keyframe_utime = tracker_.takeHeldStep();
  if (keyframe_utime && now_utime - *keyframe_utime <= micros(o_.request_timeout_s))
    stepAt(*keyframe_utime);
}

void Localizer::stepAt(int64_t keyframe_utime) {
  if (tracker_.referenceUtime() != keyframe_utime || in_flight_ || in_ride_) return;
  if (last_step_utime_ >= 0 && keyframe_utime - last_step_utime_ < micros(o_.step_interval_s))
    return;
  ++stats_.steps;
  last_step_utime_ = keyframe_utime;
  InFlight f;
  f.keyframe_utime = keyframe_utime;
  f.active = active_;
  f.delta_at_keyframe = deadReckoned();
  f.localized = localized_;
  in_flight_ = f;
  const auto target = stepTarget(keyframe_utime);
  sendRequest(target ? register_request_t::MODE_NODE : register_request_t::MODE_GLOBAL,
              target.value_or(-1));
}

std::optional<int64_t> Localizer::stepTarget(int64_t keyframe_utime) {
  if (localized_) {
    const core::SE3d world_T_body = nodePose(active_) * in_flight_->delta_at_keyframe.mean;
    const auto poses = [this](int64_t id) { return nodePose(id); };
    if (auto node = partition_.nodeAt(world_T_body, floor_, std::numeric_limits<int64_t>::max(),
                                      nodes_, poses))
      return node;
    return std::nullopt;
  }
  // A candidate placement checked where it predicts the robot is (Mapper::relocalizationCheck).
  if (!candidate_ || candidate_->verifications >= o_.relocalization_checks) return std::nullopt;
  const auto c_T_now = tracker_.sinceKeyframe(candidate_->keyframe_utime);
  if (!c_T_now) return std::nullopt;
  ++candidate_->verifications;
  const int floor = nodes_[static_cast<size_t>(candidate_->node)].floor;
  const core::SE3d world_T_body =
      nodePose(candidate_->node) * candidate_->node_T_keyframe.mean * c_T_now->mean;
  const auto poses = [this](int64_t id) { return nodePose(id); };
  const auto target =
      partition_.nodeAt(world_T_body, floor, std::numeric_limits<int64_t>::max(), nodes_, poses);
  return target ? target : std::optional<int64_t>(candidate_->node);
}

void Localizer::sendRequest(int8_t mode, int64_t target) {
  // Placed: its floor (-1 when its height is no stored floor's); before: any floor.
  const register_request_t& r =
      queueRequest(in_flight_->keyframe_utime, mode, target, placed() ? floor_ : -1, session_);
  in_flight_->request_id = r.request_id;
  in_flight_->mode = mode;
  (mode == register_request_t::MODE_NODE ? stats_.requests_node : stats_.requests_global)++;
}

void Localizer::checkTimeout(int64_t utime) {
  if (in_flight_ && utime - in_flight_->keyframe_utime > micros(o_.request_timeout_s)) {
    ++stats_.timeouts;
    in_flight_.reset();
  }
}

}  // namespace evermap::mapper
