#pragma once
// LCM wiring of the registration oracle: NODE_ADDED and REGISTER_REQUEST in, REGISTER_RESULT
// out. Messages that do not decode or fail validation are counted and dropped. Threading: the
// handlers run inside lcm.handle() on the caller's thread, the oracle's only thread.

#include <cstdint>
#include <string>

#include <lcm/lcm-cpp.hpp>

#include "core/sim/registration_oracle.h"

namespace evermap::sim {

class OracleServer {
 public:
  // Subscribes on `lcm`; both must outlive the server.
  OracleServer(lcm::LCM& lcm, RegistrationOracle& oracle);
  int64_t answered() const { return answered_; }
  int64_t dropped() const { return dropped_; }

 private:
  void onNodeAdded(const lcm::ReceiveBuffer* buffer, const std::string& channel);
  void onRequest(const lcm::ReceiveBuffer* buffer, const std::string& channel);

  lcm::LCM& lcm_;
  RegistrationOracle& oracle_;
  int64_t answered_ = 0;
  int64_t dropped_ = 0;
};

}  // namespace evermap::sim
