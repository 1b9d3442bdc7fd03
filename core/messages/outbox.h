#pragma once
// How an evermap process publishes: the encoded message with the process's envelope
// (envelope.h: its name, instance, counter and wall clock; with a key, the mac). Every publish
// of an evermap process goes through an Outbox, so that receivers can tell senders apart and,
// with a key, refuse what a stranger sent.
//
//   messages::Outbox out(lcm, signer);
//   out.publish(channels::kVoDelta, delta);
//
// Threading: publish() may be called from several threads (the Signer's counter is atomic and
// lcm::LCM::publish is thread-safe). A receiver wants one sender's messages on one channel in
// counter order: publish each channel from one thread.

#include <cstdint>
#include <string>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "core/messages/envelope.h"

namespace evermap::messages {

class Outbox {
 public:
  // `lcm` must outlive the Outbox. A default Signer: no envelope (as lcm.publish).
  Outbox(lcm::LCM& lcm, Signer signer) : lcm_(lcm), signer_(std::move(signer)) {}

  // 0 on success, as lcm::LCM::publish.
  template <typename Msg>
  int publish(const std::string& channel, const Msg& msg) const {
    std::vector<uint8_t> bytes(static_cast<size_t>(msg.getEncodedSize()));
    if (msg.encode(bytes.data(), 0, static_cast<int>(bytes.size())) < 0) return -1;
    return send(channel, std::move(bytes));
  }
  // An encoded message (e.g. a log's event; an envelope it carries is replaced by this
  // process's).
  int publishBytes(const std::string& channel, const void* data, int64_t size) const;

  const Signer& signer() const { return signer_; }
  lcm::LCM& lcm() const { return lcm_; }

 private:
  int send(const std::string& channel, std::vector<uint8_t> bytes) const;

  lcm::LCM& lcm_;
  Signer signer_;
};

}  // namespace evermap::messages
