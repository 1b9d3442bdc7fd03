#include "loopclose-proc/server.h"

#include <cstdio>

#include "core/messages/channels.h"
#include "core/messages/convert.h"

namespace evermap::loopclose {

LoopCloseServer::LoopCloseServer(lcm::LCM& lcm, LoopCloser& loop_closer)
    : lcm_(lcm), loop_closer_(loop_closer) {
  subscriptions_.push_back(lcm_.subscribe(channels::kKeyframe, &LoopCloseServer::onKeyframe, this));
  subscriptions_.push_back(
      lcm_.subscribe(channels::kNodeAdded, &LoopCloseServer::onNodeAdded, this));
  subscriptions_.push_back(
      lcm_.subscribe(channels::kRegisterRequest, &LoopCloseServer::onRequest, this));
}

LoopCloseServer::~LoopCloseServer() {
  for (lcm::Subscription* s : subscriptions_) lcm_.unsubscribe(s);
}

void LoopCloseServer::drop(const std::string& why) {
  ++dropped_;
  std::fprintf(stderr, "loopclose-proc: dropped: %s\n", why.c_str());
}

void LoopCloseServer::publishDue() {
  for (const evermap::register_result_t& r : loop_closer_.poll()) {
    lcm_.publish(channels::kRegisterResult, &r);
    ++published_;
  }
}

void LoopCloseServer::onKeyframe(const lcm::ReceiveBuffer* buffer, const std::string& channel) {
  auto m = messages::decodeLcm<evermap::keyframe_t>(buffer->data, buffer->data_size, channel);
  if (!m) return drop(m.error().message);
  if (Status s = loop_closer_.addKeyframe(*m); !s) drop(channel + ": " + s.error().message);
  publishDue();
}

void LoopCloseServer::onNodeAdded(const lcm::ReceiveBuffer* buffer, const std::string& channel) {
  auto m = messages::decodeLcm<evermap::node_added_t>(buffer->data, buffer->data_size, channel);
  if (!m) return drop(m.error().message);
  if (Status s = loop_closer_.addNode(*m); !s) drop(channel + ": " + s.error().message);
  publishDue();
}

void LoopCloseServer::onRequest(const lcm::ReceiveBuffer* buffer, const std::string& channel) {
  auto m =
      messages::decodeLcm<evermap::register_request_t>(buffer->data, buffer->data_size, channel);
  // An undecodable request has no id to answer to: it can only be counted.
  if (!m) return drop(m.error().message);
  loop_closer_.submit(*m);  // invalid content is answered (STATUS_MALFORMED) by poll()
  publishDue();
}

}  // namespace evermap::loopclose
