#pragma once
// The REGISTER_RESULT messages published on an LCM (memq:// in tests), collected as they are
// handled, for the loopclose-proc server tests.
#include <string>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include <evermap/register_result_t.hpp>

#include "core/messages/channels.h"

namespace evermap::testing {

class RegisterResults {
 public:
  explicit RegisterResults(lcm::LCM& lcm) : lcm_(lcm) {
    lcm_.subscribe(channels::kRegisterResult, &RegisterResults::on, this);
  }
  // Handles everything queued (memq:// delivers on handle()).
  void deliver() {
    while (lcm_.handleTimeout(0) > 0) {
    }
  }
  std::vector<evermap::register_result_t> results;

 private:
  void on(const lcm::ReceiveBuffer*, const std::string&, const evermap::register_result_t* r) {
    results.push_back(*r);
  }
  lcm::LCM& lcm_;
};

}  // namespace evermap::testing
