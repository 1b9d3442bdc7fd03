// The oracle over LCM (in-process, memq://): NODE_ADDED and REGISTER_REQUEST in,
// REGISTER_RESULT out; garbage is counted and dropped.
#include <gtest/gtest.h>

#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "core/messages/channels.h"
#include "tools/sim/oracle_server.h"

namespace evermap::sim {
namespace {

struct Results {
  std::vector<register_result_t> got;
  void onResult(const lcm::ReceiveBuffer*, const std::string&, const register_result_t* r) {
    got.push_back(*r);
  }
};

TEST(OracleServer, AnswersRequestsPublishedOnLcm) {
  lcm::LCM lcm("memq://");
  ASSERT_TRUE(lcm.good());
  OracleOptions o;
  o.false_match_rate_node = 0.0;
  o.success_probability = 1.0;
  o.distance_scale_m = o.angle_scale_rad = 1e6;
  o.translation_sigma_m = o.translation_sigma_per_m = o.rotation_sigma_rad =
      o.rotation_sigma_per_rad = 0.0;
  RegistrationOracle oracle(o, 1);
  const SE3d body_T_cam = CameraOptions{}.bodyTCam();
  oracle.addKeyframe(KeyframeTruth{100, body_T_cam, 0, 0});
  oracle.addKeyframe(
      KeyframeTruth{200, SE3d(core::SO3d(), Vec3(1.0, 0.0, 0.0)) * body_T_cam, 0, 0});
  OracleServer server(lcm, oracle);
  Results results;
  lcm.subscribe(channels::kRegisterResult, &Results::onResult, &results);

  node_added_t n{};
  n.utime = 100;
  n.node_id = 5;
  n.keyframe_utime = 100;
  lcm.publish(channels::kNodeAdded, &n);
  register_request_t r{};
  r.utime = 200;
  r.request_id = 77;
  r.keyframe_utime = 200;
  r.mode = register_request_t::MODE_NODE;
  r.target_node_id = 5;
  lcm.publish(channels::kRegisterRequest, &r);
  const uint8_t garbage[3] = {1, 2, 3};
  lcm.publish(channels::kRegisterRequest, garbage, sizeof garbage);
  for (int i = 0; i < 10 && results.got.empty(); ++i) lcm.handleTimeout(10);
  while (lcm.handleTimeout(0) > 0) {
  }
  ASSERT_EQ(results.got.size(), 1u);
  EXPECT_EQ(results.got[0].request_id, 77);
  EXPECT_EQ(results.got[0].status, int(register_result_t::STATUS_OK));
  EXPECT_EQ(results.got[0].node_id, 5);
  // One metre forward of the body is one metre along the camera's optical axis (z).
  EXPECT_NEAR(results.got[0].translation[2], 1.0, 1e-12);
  EXPECT_EQ(server.answered(), 1);
  EXPECT_EQ(server.dropped(), 1);
}

}  // namespace
}  // namespace evermap::sim
