#pragma once
// The messages a map consumer takes: the Mapper (mapping) and the Localizer (localization
// against a stored map) read the same channels, and their LCM nodes deliver through this.

#include <cstdint>
#include <type_traits>
#include <utility>
#include <vector>

#include <evermap/attitude_t.hpp>
#include <evermap/floor_t.hpp>
#include <evermap/register_request_t.hpp>
#include <evermap/register_result_t.hpp>
#include <evermap/vo_delta_t.hpp>
#include <evermap/wheel_odom_t.hpp>

#include "core/common/expected.h"
#include "core/geometry/se3.h"
#include "core/messages/channels.h"
#include "mapper-proc/tracker.h"

namespace evermap::mapper {

class MapInputs {
 public:
  virtual ~MapInputs() = default;
  // Each returns an error for a message it drops (also counted).
  virtual Status onVo(const vo_delta_t& msg) = 0;
  virtual Status onWheel(const wheel_odom_t& msg) = 0;
  virtual Status onAttitude(const attitude_t& msg) = 0;
  virtual Status onFloor(const floor_t& msg) = 0;
  virtual Status onRegisterResult(const register_result_t& msg) = 0;
};

// A map consumer's shared state: it tracks the robot between its nodes from VO, wheels and the
// gyro (tracker.h), and asks loopclose-proc for registrations (REGISTER_REQUEST). The Mapper
// and the Localizer are ones.
class MapConsumer : public MapInputs {
 public:
  explicit MapConsumer(const TrackerOptions& options) : tracker_(options) {}

  // The left camera's mounting (rectified body_T_cam of STEREO_CALIB, calibration_latch.h):
  // VO deltas are camera motions. Until it is set, options.tracker.body_T_cam holds.
  void setCameraMounting(const core::SE3d& body_T_cam) { tracker_.setBodyTCamera(body_T_cam); }
  const Tracker& tracker() const { return tracker_; }
  // The requests made since the last call.
  std::vector<register_request_t> takeRequests() { return std::exchange(requests_, {}); }

 protected:
  // Queues a REGISTER_REQUEST about `keyframe_utime` under the next id: in MODE_NODE against
  // node `target`, in MODE_GLOBAL an appearance search on `floor` (-1: every floor).
  const register_request_t& queueRequest(int64_t keyframe_utime, int8_t mode, int64_t target,
                                         int floor, int session) {
    register_request_t& r = requests_.emplace_back();
    r.utime = keyframe_utime;
    r.request_id = next_request_id_++;
    r.keyframe_utime = keyframe_utime;
    r.mode = mode;
    r.target_node_id = mode == register_request_t::MODE_NODE ? target : -1;
    r.floor = floor;
    r.session = session;
    return r;
  }

  Tracker tracker_;

 private:
  int64_t next_request_id_ = 1;
  std::vector<register_request_t> requests_;
};

// The five input channels subscribed on an Inbox (core/messages/inbox.h), each to `on`.
template <typename Inbox, typename Handler>
void subscribeMapInputs(Inbox& inbox, const Handler& on) {
  inbox.template subscribe<vo_delta_t>(channels::kVoDelta, on);
  inbox.template subscribe<wheel_odom_t>(channels::kWheelOdom, on);
  inbox.template subscribe<attitude_t>(channels::kAttitude, on);
  inbox.template subscribe<floor_t>(channels::kFloor, on);
  inbox.template subscribe<register_result_t>(channels::kRegisterResult, on);
}

// A decoded message to its handler.
inline Status deliver(MapInputs& in, const vo_delta_t& msg) { return in.onVo(msg); }
inline Status deliver(MapInputs& in, const wheel_odom_t& msg) { return in.onWheel(msg); }
inline Status deliver(MapInputs& in, const attitude_t& msg) { return in.onAttitude(msg); }
inline Status deliver(MapInputs& in, const floor_t& msg) { return in.onFloor(msg); }
inline Status deliver(MapInputs& in, const register_result_t& msg) {
  return in.onRegisterResult(msg);
}

// Whether a delivered message moves the published pose on: a VO frame does, wheel odometry
// while VO is not tracking.
template <typename Msg>
bool movesPose(bool vo_tracking) {
  if constexpr (std::is_same_v<Msg, vo_delta_t>) return true;
  if constexpr (std::is_same_v<Msg, wheel_odom_t>) return !vo_tracking;
  return false;
}

// The message time a delivered message sets: a result carries its query keyframe's time, so
// only sensor messages move message time on.
template <typename Msg>
int64_t messageTime(const Msg& msg, int64_t last_utime) {
  if constexpr (std::is_same_v<Msg, register_result_t>) {
    return last_utime;
  } else {
    return msg.utime;
  }
}

}  // namespace evermap::mapper
