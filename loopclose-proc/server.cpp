#include "loopclose-proc/server.h"

#include <cstdio>

#include <evermap/vo_delta_t.hpp>

#include "core/messages/channels.h"
#include "core/messages/convert.h"

namespace evermap::loopclose {

LoopCloseServer::LoopCloseServer(lcm::LCM& lcm, LoopCloser& loop_closer,
                                 messages::Inbox::Options input)
    : out_(lcm, input.signer), loop_closer_(loop_closer), inbox_(lcm, std::move(input)) {
  inbox_.subscribe<evermap::keyframe_t>(channels::kKeyframe, [this](const evermap::keyframe_t& m) {
    Status s = loop_closer_.addKeyframe(m);
    publishDue();
    return s;
  });
  // Parts of keyframes asked for again come in bursts of tens (a 37 KB keyframe is 31).
  inbox_.subscribe<evermap::keyframe_part_t>(
      channels::kKeyframePart,
      [this](const evermap::keyframe_part_t& m) {
        Status s = loop_closer_.addKeyframePart(m);
        publishDue();
        return s;
      },
      1000);
  inbox_.subscribe<evermap::node_added_t>(channels::kNodeAdded,
                                          [this](const evermap::node_added_t& m) {
                                            Status s = loop_closer_.addNode(m);
                                            publishDue();
                                            return s;
                                          });
  // An undecodable request has no id to answer to: the Inbox only counts it. Invalid content
  // is answered (STATUS_MALFORMED) by poll().
  inbox_.subscribe<evermap::register_request_t>(channels::kRegisterRequest,
                                                [this](const evermap::register_request_t& m) {
                                                  loop_closer_.submit(m);
                                                  publishDue();
                                                });
  // The mapper's map: nodes whose NODE_ADDED was lost (one datagram) are caught up from it.
  inbox_.subscribe<evermap::map_graph_t>(
      channels::kMapGraph,
      [this](const evermap::map_graph_t& m) {
        loop_closer_.catchUpNodes(m);
        publishDue();
      },
      2);  // the newest matters; a large map is MBs
  // The clock: keyframes and requests come about once a second, and the time guard holds
  // messages until three distinct stamps agree, so a clock set by them alone held a session's
  // first request for three seconds of data (the robot had left the place it showed by the
  // time the answer came). VO frames come at 20-30 Hz.
  inbox_.subscribe<evermap::vo_delta_t>(channels::kVoDelta, [this](const evermap::vo_delta_t& m) {
    loop_closer_.advanceClock(m.utime);
    publishDue();
  });
}

int64_t LoopCloseServer::dropped() const { return inbox_.total().dropped(); }

void LoopCloseServer::publishDue() {
  // The asks first: a node that waited for a keyframe given up is reported below.
  for (const evermap::keyframe_request_t& r : loop_closer_.takeKeyframeRequests())
    out_.publish(channels::kKeyframeRequest, r);
  for (const std::string& why : loop_closer_.takeNodeErrors())
    inbox_.countRefused(channels::kNodeAdded, std::string(channels::kNodeAdded) + ": " + why);
  for (const evermap::register_result_t& r : loop_closer_.poll()) {
    out_.publish(channels::kRegisterResult, r);
    ++published_;
  }
}

}  // namespace evermap::loopclose
