#pragma once
// LCM wiring of loopclose-proc: KEYFRAME, NODE_ADDED and REGISTER_REQUEST in, REGISTER_RESULT
// out. Messages that do not decode or fail validation are logged (one line) and counted; the
// answers due are published after every message received (time is data time, so nothing is
// due between messages). Threading: handlers run inside lcm.handle() on the caller's thread,
// the LoopCloser's only thread.

#include <cstdint>
#include <string>

#include <lcm/lcm-cpp.hpp>

#include "loopclose-proc/loop_closer.h"

namespace evermap::loopclose {

class LoopCloseServer {
 public:
  // Subscribes on `lcm`; both must outlive the server.
  LoopCloseServer(lcm::LCM& lcm, LoopCloser& loop_closer);
  LoopCloseServer(const LoopCloseServer&) = delete;
  LoopCloseServer& operator=(const LoopCloseServer&) = delete;
  ~LoopCloseServer();

  int64_t dropped() const { return dropped_; }     // undecodable or invalid messages
  int64_t published() const { return published_; }

 private:
  void onKeyframe(const lcm::ReceiveBuffer* buffer, const std::string& channel);
  void onNodeAdded(const lcm::ReceiveBuffer* buffer, const std::string& channel);
  void onRequest(const lcm::ReceiveBuffer* buffer, const std::string& channel);
  void drop(const std::string& why);
  void publishDue();

  lcm::LCM& lcm_;
  LoopCloser& loop_closer_;
  std::vector<lcm::Subscription*> subscriptions_;
  int64_t dropped_ = 0;
  int64_t published_ = 0;
};

}  // namespace evermap::loopclose
