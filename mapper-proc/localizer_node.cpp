#include "mapper-proc/localizer_node.h"

#include <algorithm>
#include <sstream>

#include <evermap/attitude_t.hpp>
#include <evermap/floor_t.hpp>
#include <evermap/localization_t.hpp>
#include <evermap/register_result_t.hpp>
#include <evermap/rgbd_calib_t.hpp>
#include <evermap/vo_delta_t.hpp>
#include <evermap/wheel_odom_t.hpp>

#include "core/messages/channels.h"
#include "core/messages/convert.h"

namespace evermap::mapper {

LocalizerNode::LocalizerNode(lcm::LCM& lcm, Localizer& localizer, const LcmNodeOptions& options)
    : out_(lcm, options.input.signer), l_(localizer), inbox_(lcm, options.input) {
  auto on = [this](const auto& msg) { return this->on(msg); };
  subscribeMapInputs(inbox_, on);
  const auto set = [this](const core::SE3d& m) { l_.setCameraMounting(m); };
  inbox_.subscribeBytes<stereo_calib_t>(
      channels::kStereoCalib,
      [this, set](const void* data, int64_t size) { return calibration_.handle(data, size, set); });
  inbox_.subscribeBytes<rgbd_calib_t>(channels::kRgbdCalib,
                                      [this, set](const void* data, int64_t size) {
                                        return calibration_.handleRgbd(data, size, set);
                                      });
}

template <typename Msg>
Status LocalizerNode::on(const Msg& msg) {
  if constexpr (std::is_same_v<Msg, vo_delta_t>) {
    if (!calibration_.haveCamera()) {
      ++no_calibration_;
      return makeError("VO_DELTA ", msg.utime, ": no STEREO_CALIB received yet (", no_calibration_,
                       " so far)");
    }
  }
  if (Status s = deliver(l_, msg); !s) {
    ++refused_;
    return s;
  }
  afterMessage(messageTime(msg, last_utime_), movesPose<Msg>(l_.tracker().voTracking()));
  return Ok{};
}

void LocalizerNode::afterMessage(int64_t utime, bool publish_pose) {
  last_utime_ = std::max(last_utime_, utime);
  for (const auto& r : l_.takeRequests()) out_.publish(channels::kRegisterRequest, r);
  if (!publish_pose) return;
  localization_t m{};
  m.utime = utime;
  m.placed = l_.placed();
  m.localized = l_.localized();
  m.node_id = l_.activeNode();
  m.pose = messages::toMsg(utime, l_.pose(), l_.floor(), l_.session());
  out_.publish(channels::kLocalization, m);
  if (!l_.placed()) return;
  out_.publish(channels::kPose, m.pose);
  ++poses_;
  if (m.localized) ++localized_poses_;
}

int64_t LocalizerNode::dropped() const {
  int64_t n = refused_ + no_calibration_ + calibration_.counts().undecodable +
              calibration_.counts().refused;
  for (const auto& [channel, k] : inbox_.counts()) n += k.malformed + k.time_refused + k.failed;
  return n;
}

std::string LocalizerNode::summary() const {
  const LocalizerStats& s = l_.stats();
  std::ostringstream o;
  o << "poses_published " << poses_ << "\nlocalized_poses " << localized_poses_ << "\nsteps "
    << s.steps << "\nrequests_node " << s.requests_node << "\nrequests_global " << s.requests_global
    << "\nplacements " << s.placements << "\ncorrections " << s.corrections << "\nrefused_gate "
    << s.refused_gate << "\ngate_recoveries " << s.gate_recoveries << "\nrefused_floor "
    << s.refused_floor << "\nunlocalized " << s.unlocalized << "\nvertical_alarms "
    << s.vertical_alarms << "\ndropped " << dropped() << "\n";
  return o.str();
}

}  // namespace evermap::mapper
