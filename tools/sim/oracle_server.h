#pragma once
// LCM wiring of the registration oracle: NODE_ADDED and REGISTER_REQUEST in, REGISTER_RESULT
// out. Messages that do not decode or fail validation are counted and dropped; both queues are
// unbounded (LCM 1.3.1 drops beyond 30 otherwise, docs/lcm.md). Threading: the
// handlers run inside lcm.handle() on the caller's thread, the oracle's only thread.

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

#include <lcm/lcm-cpp.hpp>

#include "core/common/expected.h"
#include "core/messages/outbox.h"
#include "tools/sim/registration_oracle.h"

namespace evermap::sim {

// Tells the oracle the nodes a map store already holds (the mapper's `map_nodes` table,
// mapper-proc/map_store.h), so an oracle restarted mid-run answers for nodes announced before
// it started, as loopclose-proc does from its own store. Read-only; a store without that table
// yet (the mapper has not created it) holds no nodes. Returns how many nodes were told; an
// error names the file.
Expected<int64_t> loadStoredNodes(RegistrationOracle& oracle, const std::filesystem::path& store);

class OracleServer {
 public:
  // Subscribes on `lcm`; both must outlive the server. Results go out sealed by `signer`
  // (core/messages/envelope.h); what arrives is read without its envelope, unchecked.
  OracleServer(lcm::LCM& lcm, RegistrationOracle& oracle, messages::Signer signer = {});
  int64_t answered() const { return answered_; }
  int64_t dropped() const { return dropped_; }

 private:
  void onNodeAdded(const lcm::ReceiveBuffer* buffer, const std::string& channel);
  void onRequest(const lcm::ReceiveBuffer* buffer, const std::string& channel);
  // The message in `buffer`, or nothing (counted in dropped_, one line) when it does not decode.
  template <typename Msg>
  std::optional<Msg> decode(const lcm::ReceiveBuffer* buffer, const std::string& channel);

  lcm::LCM& lcm_;
  messages::Outbox out_;
  RegistrationOracle& oracle_;
  int64_t answered_ = 0;
  int64_t dropped_ = 0;
};

}  // namespace evermap::sim
