#include "loopclose-proc/server.h"

#include <cstdio>

#include "core/messages/channels.h"
#include "core/messages/convert.h"

namespace evermap::loopclose {

LoopCloseServer::LoopCloseServer(lcm::LCM& lcm, LoopCloser& loop_closer,
                                 messages::Inbox::Options input)
    : lcm_(lcm), loop_closer_(loop_closer), inbox_(lcm, std::move(input)) {
  inbox_.subscribe<evermap::keyframe_t>(channels::kKeyframe, [this](const evermap::keyframe_t& m) {
    Status s = loop_closer_.addKeyframe(m);
    publishDue();
    return s;
  });
  inbox_.subscribe<evermap::node_added_t>(channels::kNodeAdded, [this](const evermap::node_added_t& m) {
    Status s = loop_closer_.addNode(m);
    publishDue();
    return s;
  });
  // An undecodable request has no id to answer to: the Inbox only counts it. Invalid content
  // is answered (STATUS_MALFORMED) by poll().
  inbox_.subscribe<evermap::register_request_t>(
      channels::kRegisterRequest, [this](const evermap::register_request_t& m) {
        loop_closer_.submit(m);
        publishDue();
      });
}

int64_t LoopCloseServer::dropped() const { return inbox_.total().dropped(); }

void LoopCloseServer::publishDue() {
  for (const evermap::register_result_t& r : loop_closer_.poll()) {
    lcm_.publish(channels::kRegisterResult, &r);
    ++published_;
  }
}

}  // namespace evermap::loopclose
