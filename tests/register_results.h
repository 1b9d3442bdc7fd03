#pragma once
// For the loopclose-proc tests: the REGISTER_RESULT messages published on an LCM (memq:// in
// tests), collected as they are handled; the status and mode constants; the messages they send.
#include <cstdint>
#include <string>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include <evermap/keyframe_t.hpp>
#include <evermap/node_added_t.hpp>
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

// NODE_ADDED for node `id` made at keyframe `keyframe_utime` on `floor`.
inline node_added_t nodeAdded(int64_t id, int64_t keyframe_utime, int32_t floor) {
  node_added_t n{};
  n.utime = keyframe_utime;
  n.node_id = id;
  n.keyframe_utime = keyframe_utime;
  n.floor = floor;
  return n;
}

// REGISTER_REQUEST `id` sent at `utime` for keyframe `keyframe`; `target` the node (MODE_NODE).
inline register_request_t registerRequest(int64_t id, int64_t utime, int64_t keyframe, int8_t mode,
                                          int64_t target = -1, int32_t floor = -1) {
  register_request_t r{};
  r.utime = utime;
  r.request_id = id;
  r.keyframe_utime = keyframe;
  r.mode = mode;
  r.target_node_id = target;
  r.floor = floor;
  return r;
}

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
