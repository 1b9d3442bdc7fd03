#include "tools/mapper-run/oracle_broker.h"

#include <algorithm>

#include <evermap/attitude_t.hpp>
#include <evermap/floor_t.hpp>
#include <evermap/vo_delta_t.hpp>
#include <evermap/wheel_odom_t.hpp>

#include "core/messages/channels.h"
#include "core/messages/convert.h"

namespace evermap::mapper {

void OracleBroker::write(const std::string& channel, int64_t utime,
                         const std::vector<uint8_t>& data) {
  if (!deliver_) return;
  const bool floor = channel == channels::kFloor;
  if (utime <= resume_utime_ && (!floor || !floors_before_resume_)) return;
  ++messages_;
  const int64_t size = static_cast<int64_t>(data.size());
  if (channel == channels::kVoDelta) {
    deliver(messages::decodeLcm<vo_delta_t>(data.data(), size, channel));
  } else if (channel == channels::kWheelOdom) {
    deliver(messages::decodeLcm<wheel_odom_t>(data.data(), size, channel));
  } else if (channel == channels::kAttitude) {
    deliver(messages::decodeLcm<attitude_t>(data.data(), size, channel));
  } else if (floor) {
    deliver(messages::decodeLcm<floor_t>(data.data(), size, channel));
  }
  pump();
  if (after_message_) after_message_(utime);
}

void OracleBroker::keyframeKnown(int64_t utime) {
  known_keyframe_ = std::max(known_keyframe_, utime);
  pump();
}

void OracleBroker::pump() {
  for (;;) {
    for (auto& n : mapper_.takeNodesAdded()) nodes_.push_back(n);
    for (auto& r : mapper_.takeRequests()) requests_.push_back(r);
    bool progressed = false;
    while (!nodes_.empty() && nodes_.front().keyframe_utime <= known_keyframe_) {
      oracle_.addNode(nodes_.front());
      if (on_node_) on_node_(nodes_.front());
      nodes_.pop_front();
      progressed = true;
    }
    if (!requests_.empty() && requests_.front().keyframe_utime <= known_keyframe_ &&
        nodes_.empty()) {
      const register_request_t r = requests_.front();
      requests_.pop_front();
      const auto answer = oracle_.answerWithTruth(r);
      if (answer.false_match) ++false_matches_;
      (void)mapper_.onRegisterResult(answer.result);
      progressed = true;
    }
    if (!progressed) return;
  }
}

}  // namespace evermap::mapper
