#pragma once
// For the loopclose-proc tests: the REGISTER_RESULT messages published on an LCM (memq:// in
// tests), collected as they are handled; the status and mode constants; a keyframe message.
#include <cstdint>
#include <string>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include <evermap/keyframe_t.hpp>
#include <evermap/register_request_t.hpp>
#include <evermap/register_result_t.hpp>

#include "core/messages/channels.h"

namespace evermap::testing {

// lcm-gen declares the status constants without a definition: EXPECT_EQ binds references, so
// the tests compare against these copies.
constexpr int kOk = register_result_t::STATUS_OK;
constexpr int kNoCandidate = register_result_t::STATUS_NO_CANDIDATE;
constexpr int kTooFewInliers = register_result_t::STATUS_TOO_FEW_INLIERS;
constexpr int kUnknownNode = register_result_t::STATUS_UNKNOWN_NODE;
constexpr int kUnknownKeyframe = register_result_t::STATUS_UNKNOWN_KEYFRAME;
constexpr int kMalformed = register_result_t::STATUS_MALFORMED;
constexpr int kStale = register_result_t::STATUS_STALE;
constexpr int8_t kNode = register_request_t::MODE_NODE;
constexpr int8_t kGlobal = register_request_t::MODE_GLOBAL;
constexpr int64_t kSecond = 1'000'000;

// A keyframe message at `utime` without features, from a 640x480 camera (fx = fy = 450 px,
// 0.11 m baseline).
inline keyframe_t emptyKeyframe(int64_t utime) {
  keyframe_t k;
  k.utime = utime;
  k.fx = k.fy = 450.0;
  k.cx = 320.0;
  k.cy = 240.0;
  k.baseline_m = 0.11;
  k.num_features = 0;
  return k;
}

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
