#pragma once
// LCM wiring of loopclose-proc: KEYFRAME, KEYFRAME_PART (keyframes asked for again),
// NODE_ADDED, REGISTER_REQUEST and MAP_GRAPH (nodes whose NODE_ADDED was lost) in,
// REGISTER_RESULT and KEYFRAME_REQUEST (missed keyframes asked again) out, through a
// messages::Inbox (one decoding path, bounded queues, the time guard, exceptions caught). Messages
// that do not decode or fail validation are logged (one line) and counted; the answers due are
// published after every message received (time is data time, so nothing is due between messages).
// Threading: handlers run inside lcm.handle() on the caller's thread, the LoopCloser's only thread.

#include <cstdint>
#include <string>

#include <lcm/lcm-cpp.hpp>

#include "core/messages/inbox.h"
#include "core/messages/outbox.h"
#include "loopclose-proc/loop_closer.h"

namespace evermap::loopclose {

class LoopCloseServer {
 public:
  // Subscribes on `lcm`; both must outlive the server.
  LoopCloseServer(lcm::LCM& lcm, LoopCloser& loop_closer,
                  messages::Inbox::Options input = defaultInput());
  static messages::Inbox::Options defaultInput() {
    messages::Inbox::Options o;
    o.process = "loopclose-proc";
    // NODE_ADDED and REGISTER_REQUEST come at the mapper's pace (a few per second) and each
    // is answered; KEYFRAME is cached, the newest matter: 100 of each bounds a flood to
    // ~100 keyframes (~50 MB) while a registration runs.
    o.queue_capacity = 100;
    return o;
  }
  LoopCloseServer(const LoopCloseServer&) = delete;
  LoopCloseServer& operator=(const LoopCloseServer&) = delete;

  int64_t dropped() const;  // undecodable, refused or invalid messages
  const messages::Inbox& inbox() const { return inbox_; }
  messages::Inbox& inbox() { return inbox_; }
  int64_t published() const { return published_; }

 private:
  void publishDue();

  messages::Outbox out_;  // sealed with input.signer
  LoopCloser& loop_closer_;
  int64_t published_ = 0;
  messages::Inbox inbox_;  // last: its handlers use the members above
};

}  // namespace evermap::loopclose
