#pragma once
// Between the measurement-level simulator, the mapper and the registration oracle in
// evermap-mapper-run (offline_run.h): the simulator's messages, decoded, to the mapper; the
// mapper's registration requests to the oracle and its answers back; the mapper's new nodes to
// the oracle. Nodes and requests wait until the oracle knows their keyframe.

#include <cstdint>
#include <deque>
#include <functional>
#include <string>
#include <vector>

#include "core/common/expected.h"
#include "mapper-proc/mapper.h"
#include "tools/sim/message_sink.h"
#include "tools/sim/registration_oracle.h"

namespace evermap::mapper {

// Feeds decoded messages to the mapper and brokers its requests with the oracle. Messages
// before `resume_utime` (a restored map) reach the mapper only when they are FLOOR messages;
// with `deliver` off none do (sessions simulated only for the oracle).
class OracleBroker final : public sim::MessageSink {
 public:
  OracleBroker(Mapper& mapper, sim::RegistrationOracle& oracle)
      : mapper_(mapper), oracle_(oracle) {}

  void write(const std::string& channel, int64_t utime, const std::vector<uint8_t>& data) override;
  void setAfterMessage(std::function<void(int64_t)> f) { after_message_ = std::move(f); }
  void setOnNode(std::function<void(const node_added_t&)> f) { on_node_ = std::move(f); }
  void setDeliver(bool deliver) { deliver_ = deliver; }
  void setResumeUtime(int64_t utime, bool floors_before) {
    resume_utime_ = utime;
    floors_before_resume_ = floors_before;
  }

  // Called by the simulator's observer when a keyframe's truth is known.
  void keyframeKnown(int64_t utime);

  int64_t messages() const { return messages_; }
  int64_t decodeErrors() const { return decode_errors_; }
  int64_t falseMatches() const { return false_matches_; }

 private:
  template <typename Msg>
  void deliver(const Expected<Msg>& msg) {
    if (!msg) {
      ++decode_errors_;
      return;
    }
    (void)apply(*msg);  // drops are counted by the mapper
  }
  Status apply(const vo_delta_t& m) { return mapper_.onVo(m); }
  Status apply(const wheel_odom_t& m) { return mapper_.onWheel(m); }
  Status apply(const attitude_t& m) { return mapper_.onAttitude(m); }
  Status apply(const floor_t& m) { return mapper_.onFloor(m); }

  // Nodes and requests wait until the oracle knows their keyframe; answers may raise new
  // requests (node mode, then global), so this loops until nothing is ready.
  void pump();

  Mapper& mapper_;
  sim::RegistrationOracle& oracle_;
  std::deque<node_added_t> nodes_;
  std::deque<register_request_t> requests_;
  int64_t known_keyframe_ = -1;
  int64_t messages_ = 0;
  int64_t decode_errors_ = 0;
  int64_t false_matches_ = 0;
  bool deliver_ = true;
  int64_t resume_utime_ = -1;
  bool floors_before_resume_ = true;
  std::function<void(int64_t)> after_message_;
  std::function<void(const node_added_t&)> on_node_;
};

}  // namespace evermap::mapper
