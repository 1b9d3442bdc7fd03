#pragma once
// The localizer on LCM (evermap-mapper-proc --localize, docs/localization.md): subscribes to
// STEREO_CALIB (or RGBD_CALIB), VO_DELTA, WHEEL_ODOM, ATTITUDE, FLOOR and REGISTER_RESULT, feeds
// the Localizer, publishes its REGISTER_REQUEST, and after every VO frame (and wheel increment
// while VO is down) POSE (once placed on the map) and LOCALIZATION (the localized flag, the
// node, the pose). No NODE_ADDED, no MAP_GRAPH, no store write: the map store was read once,
// read-only. Input goes through a messages::Inbox as the mapper's (lcm_node.h).

#include <cstdint>
#include <string>

#include <lcm/lcm-cpp.hpp>

#include "core/messages/inbox.h"
#include "core/messages/outbox.h"
#include "mapper-proc/calibration_latch.h"
#include "mapper-proc/lcm_node.h"
#include "mapper-proc/localizer.h"

namespace evermap::mapper {

class LocalizerNode {
 public:
  // `lcm` and `localizer` must outlive the node. options: the mapper node's (input only).
  LocalizerNode(lcm::LCM& lcm, Localizer& localizer, const LcmNodeOptions& options);

  int64_t lastUtime() const { return last_utime_; }
  int64_t dropped() const;
  // A one-line-per-figure summary for the end of a run.
  std::string summary() const;

 private:
  template <typename Msg>
  Status on(const Msg& msg);
  void afterMessage(int64_t utime, bool publish_pose);

  messages::Outbox out_;
  Localizer& l_;
  CalibrationLatch calibration_;
  int64_t last_utime_ = -1;
  int64_t refused_ = 0, no_calibration_ = 0, poses_ = 0, localized_poses_ = 0;
  messages::Inbox inbox_;  // last: its handlers use the members above
};

}  // namespace evermap::mapper
