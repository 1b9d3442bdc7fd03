// The registration oracle: exact answers without noise, the configured false-match rate,
// success falling with distance and view angle, honest covariances, and error statuses.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "sim_test_support.h"
#include "tests/register_results.h"
#include "tools/sim/registration_oracle.h"
#include "tools/sim/request_load.h"
#include "tools/sim/sim_message_conversions.h"

namespace evermap::sim {
namespace {

using evermap::testing::kOk;

// A camera looking along world x (its z axis), at (x, y, 1.2) on `floor`, turned by yaw.
KeyframeTruth camera(int64_t utime, double x, double y, double yaw, int floor = 0) {
  const core::SO3d body = core::SO3d::fromRollPitchYaw(0.0, 0.0, yaw);
  const SE3d world_T_body(body, Vec3(x, y, 4.0 * floor));
  return KeyframeTruth{utime, world_T_body * CameraOptions{}.bodyTCam(), floor, 0};
}

node_added_t node(int64_t id, int64_t keyframe_utime, int floor = 0) {
  return evermap::testing::nodeAdded(id, keyframe_utime, floor);
}

// Sent at the keyframe's time.
register_request_t request(int64_t id, int64_t keyframe_utime, int8_t mode, int64_t target = -1,
                           int floor = 0) {
  return evermap::testing::registerRequest(id, keyframe_utime, keyframe_utime, mode, target, floor);
}

OracleOptions exact() {
  OracleOptions o;
  o.translation_sigma_m = o.translation_sigma_per_m = 0.0;
  o.rotation_sigma_rad = o.rotation_sigma_per_rad = 0.0;
  o.false_match_rate_node = o.false_match_rate_global = 0.0;
  o.success_probability = 1.0;
  o.distance_scale_m = 1e6;
  o.angle_scale_rad = 1e6;
  return o;
}

TEST(RegistrationOracle, NoiseFreeAnswersEqualTheTrueRelativePose) {
  RegistrationOracle oracle(exact(), 1);
  const KeyframeTruth a = camera(1000, 0.0, 0.0, 0.0);
  const KeyframeTruth b = camera(2000, 1.5, -0.7, 0.3);
  oracle.addKeyframe(a);
  oracle.addKeyframe(b);
  ASSERT_TRUE(oracle.addNode(node(7, a.utime)));
  const SE3d truth = a.world_T_cam.inverse() * b.world_T_cam;
  for (int8_t mode : {register_request_t::MODE_NODE, register_request_t::MODE_GLOBAL}) {
    const register_result_t r = oracle.answer(request(1, b.utime, mode, 7));
    ASSERT_EQ(r.status, kOk) << r.reason;
    EXPECT_EQ(r.node_id, 7);
    EXPECT_EQ(r.request_id, 1);
    EXPECT_EQ(r.keyframe_utime, b.utime);
    const SE3d got = relativePoseOf(r);
    EXPECT_LT((got.translation() - truth.translation()).norm(), 1e-12);
    EXPECT_LT(core::rotationAngle(got.so3().inverse() * truth.so3()), 1e-12);
    EXPECT_TRUE(readCovariance(r.covariance).isZero());
    EXPECT_GE(r.num_inliers, OracleOptions{}.min_inliers);
  }
}

TEST(RegistrationOracle, FalseMatchRateIsCloseToTheConfiguredRate) {
  OracleOptions o;
  o.false_match_rate_node = 0.05;
  o.false_match_rate_global = 0.1;
  RegistrationOracle oracle(o, 2);
  // A corridor of nodes every metre, queries beside them.
  for (int i = 0; i < 100; ++i) {
    oracle.addKeyframe(camera(1000 + i, i, 0.0, 0.0));
  }
  for (int i = 0; i < 100; ++i) ASSERT_TRUE(oracle.addNode(node(i, 1000 + i)));
  for (int i = 0; i < 100; ++i) oracle.addKeyframe(camera(5000 + i, i + 0.3, 0.2, 0.1));
  const int n = 20000;
  int false_node = 0;
  int false_global = 0;
  for (int k = 0; k < n; ++k) {
    const int i = k % 100;
    const auto a = oracle.answerWithTruth(request(k, 5000 + i, register_request_t::MODE_NODE, i));
    if (a.false_match) {
      ++false_node;
      EXPECT_EQ(a.result.status, kOk);
      // Wrong by at least 0.5 m: a real error, not noise.
      const SE3d truth = camera(1000 + i, i, 0, 0).world_T_cam.inverse() *
                         camera(0, i + 0.3, 0.2, 0.1).world_T_cam;
      EXPECT_GT((relativePoseOf(a.result).translation() - truth.translation()).norm(), 0.5);
    }
    const auto g =
        oracle.answerWithTruth(request(n + k, 5000 + i, register_request_t::MODE_GLOBAL));
    if (g.false_match) {
      ++false_global;
      EXPECT_EQ(g.result.status, kOk);
      EXPECT_GT(std::abs(static_cast<double>(g.result.node_id - i)), 4.0)
          << "a false node is not a near one";
    }
  }
  // Within 4 standard deviations of the binomial count.
  EXPECT_NEAR(false_node, 0.05 * n, 4.0 * std::sqrt(n * 0.05 * 0.95));
  EXPECT_NEAR(false_global, 0.1 * n, 4.0 * std::sqrt(n * 0.1 * 0.9));
  EXPECT_EQ(oracle.summary().false_node, false_node);
  EXPECT_EQ(oracle.summary().false_global, false_global);
}

TEST(RegistrationOracle, SuccessFallsWithDistanceAndViewAngleAsModelled) {
  OracleOptions o;
  o.false_match_rate_node = 0.0;
  RegistrationOracle oracle(o, 3);
  EXPECT_NEAR(oracle.successProbability(0.0, 0.0), o.success_probability, 1e-12);
  EXPECT_GT(oracle.successProbability(1.0, 0.0), oracle.successProbability(2.0, 0.0));
  EXPECT_GT(oracle.successProbability(1.0, 0.1), oracle.successProbability(1.0, 0.4));
  EXPECT_EQ(oracle.successProbability(o.max_distance_m + 0.1, 0.0), 0.0);
  EXPECT_EQ(oracle.successProbability(0.0, o.max_view_angle_rad + 0.1), 0.0);
  // Empirical rate at 2 m and 0.3 rad against the model.
  oracle.addKeyframe(camera(1, 0.0, 0.0, 0.0));
  oracle.addKeyframe(
      camera(2, -2.0, 0.0, 0.3));  // behind, so both see the same way (optical axes 0.3 apart)
  ASSERT_TRUE(oracle.addNode(node(0, 1)));
  const double p = oracle.successProbability(2.0, 0.3);
  const int n = 10000;
  int ok = 0;
  for (int k = 0; k < n; ++k)
    ok += oracle.answer(request(k, 2, register_request_t::MODE_NODE, 0)).status == kOk;
  EXPECT_NEAR(ok, p * n, 4.0 * std::sqrt(n * p * (1 - p)));
}

// fitReach (the oracle's model fitted to a registration's successes, evermap-slam-run's
// summary) gives back the parameters of an oracle whose answers it is fed: requests at
// random distances and view angles, a success being an answer that registered.
TEST(RegistrationOracle, TheReachFittedToAnOraclesAnswersIsItsModel) {
  OracleOptions o;
  o.false_match_rate_node = 0.0;
  o.success_probability = 0.9;
  o.distance_scale_m = 1.3;
  o.angle_scale_rad = 0.6;
  RegistrationOracle oracle(o, 5);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> distance(0.0, 4.0), angle(0.0, 1.2);
  std::vector<ReachSample> samples;
  for (int k = 0; k < 6000; ++k) {
    const double d = distance(rng), a = angle(rng);
    // The node looks along +z from the origin; the query stands d behind it, turned by a.
    oracle.addKeyframe(camera(2 * k + 1, 0.0, 0.0, 0.0));
    oracle.addKeyframe(camera(2 * k + 2, -d, 0.0, a));
    ASSERT_TRUE(oracle.addNode(node(k, 2 * k + 1)));
    const bool ok =
        oracle.answer(request(k, 2 * k + 2, register_request_t::MODE_NODE, k)).status == kOk;
    samples.push_back({d, a, ok});
  }
  const ReachFit fit = fitReach(samples, o);
  std::printf("fit: P %.2f, D %.2f m, A %.2f rad over %lld (beyond the bounds: %lld, %lld ok)\n",
              fit.success_probability, fit.distance_scale_m, fit.angle_scale_rad,
              static_cast<long long>(fit.samples), static_cast<long long>(fit.beyond),
              static_cast<long long>(fit.ok_beyond));
  EXPECT_NEAR(fit.success_probability, 0.9, 0.05);
  EXPECT_NEAR(fit.distance_scale_m, 1.3, 0.1);
  EXPECT_NEAR(fit.angle_scale_rad, 0.6, 0.06);
  EXPECT_GT(fit.beyond, 0);     // angles over max_view_angle_rad (1 rad)
  EXPECT_EQ(fit.ok_beyond, 0);  // which the oracle never registers
  EXPECT_EQ(fit.samples + fit.beyond, 6000);
}

TEST(RegistrationOracle, ReportedCovarianceMatchesTheNoise) {
  OracleOptions o;
  o.false_match_rate_node = 0.0;
  o.success_probability = 1.0;
  RegistrationOracle oracle(o, 4);
  const KeyframeTruth a = camera(1, 0.0, 0.0, 0.0);
  const KeyframeTruth b = camera(2, 1.0, 0.5, 0.2);
  oracle.addKeyframe(a);
  oracle.addKeyframe(b);
  ASSERT_TRUE(oracle.addNode(node(0, 1)));
  const SE3d truth = a.world_T_cam.inverse() * b.world_T_cam;
  double sum = 0.0;
  int n = 0;
  for (int k = 0; k < 5000; ++k) {
    const register_result_t r = oracle.answer(request(k, 2, register_request_t::MODE_NODE, 0));
    if (r.status != kOk) continue;
    const core::Vec6 e = (truth.inverse() * relativePoseOf(r)).log();
    sum += e.dot(readCovariance(r.covariance).ldlt().solve(e));
    ++n;
  }
  ASSERT_GT(n, 1000);
  EXPECT_NEAR(sum / n, 6.0, 0.3);
}

TEST(RegistrationOracle, GlobalSearchStaysOnTheRequestedFloorAndTrueFloor) {
  RegistrationOracle oracle(exact(), 5);
  oracle.addKeyframe(camera(1, 0.0, 0.0, 0.0, 0));
  oracle.addKeyframe(camera(2, 0.0, 0.0, 0.0, 1));
  oracle.addKeyframe(camera(3, 0.5, 0.0, 0.0, 1));
  ASSERT_TRUE(oracle.addNode(node(10, 1, 0)));
  ASSERT_TRUE(oracle.addNode(node(11, 2, 1)));
  const register_result_t on1 =
      oracle.answer(request(1, 3, register_request_t::MODE_GLOBAL, -1, 1));
  ASSERT_EQ(on1.status, kOk);
  EXPECT_EQ(on1.node_id, 11);
  // Searching floor 0 finds only node 10, which is on another true floor: no registration.
  const register_result_t on0 =
      oracle.answer(request(2, 3, register_request_t::MODE_GLOBAL, -1, 0));
  EXPECT_EQ(on0.status, int(register_result_t::STATUS_NO_CANDIDATE));
  // The same holds for a direct request against node 10.
  EXPECT_EQ(oracle.answer(request(3, 3, register_request_t::MODE_NODE, 10)).status,
            int(register_result_t::STATUS_TOO_FEW_INLIERS));
}

TEST(RegistrationOracle, BadRequestsGetAStatusNotACrash) {
  RegistrationOracle oracle(exact(), 6);
  oracle.addKeyframe(camera(1, 0.0, 0.0, 0.0));
  oracle.addKeyframe(camera(2, 30.0, 0.0, 0.0));
  EXPECT_EQ(oracle.answer(request(1, 2, register_request_t::MODE_GLOBAL)).status,
            int(register_result_t::STATUS_NO_CANDIDATE));  // no nodes yet
  ASSERT_TRUE(oracle.addNode(node(0, 1)));
  EXPECT_FALSE(oracle.addNode(node(1, 999)));  // unknown keyframe
  EXPECT_EQ(oracle.summary().nodes_without_keyframe, 1);
  EXPECT_EQ(oracle.answer(request(2, 999, register_request_t::MODE_NODE, 0)).status,
            int(register_result_t::STATUS_UNKNOWN_KEYFRAME));
  EXPECT_EQ(oracle.answer(request(3, 2, register_request_t::MODE_NODE, 42)).status,
            int(register_result_t::STATUS_UNKNOWN_NODE));
  EXPECT_EQ(oracle.answer(request(4, 2, 9, 0)).status, int(register_result_t::STATUS_MALFORMED));
  // 30 m away: beyond max_distance_m.
  EXPECT_EQ(oracle.answer(request(5, 2, register_request_t::MODE_NODE, 0)).status,
            int(register_result_t::STATUS_TOO_FEW_INLIERS));
  EXPECT_EQ(oracle.answer(request(6, 2, register_request_t::MODE_GLOBAL)).status,
            int(register_result_t::STATUS_NO_CANDIDATE));
}

TEST(RegistrationOracle, KeyframeWindowForgetsOldKeyframes) {
  OracleOptions o = exact();
  o.keyframe_window_s = 10.0;
  RegistrationOracle oracle(o, 7);
  oracle.addKeyframe(camera(1000000, 0.0, 0.0, 0.0));
  oracle.addKeyframe(camera(5000000, 0.0, 0.0, 0.0));
  EXPECT_TRUE(oracle.addNode(node(0, 1000000)));
  oracle.addKeyframe(camera(20000000, 0.0, 0.0, 0.0));
  EXPECT_FALSE(oracle.addNode(node(1, 1000000)));
  EXPECT_TRUE(oracle.addNode(node(2, 20000000)));
}

TEST(RegistrationOracle, SameSeedGivesTheSameAnswers) {
  auto run = [](uint64_t seed) {
    RegistrationOracle oracle(OracleOptions{}, seed);
    for (int i = 0; i < 50; ++i) oracle.addKeyframe(camera(i + 1, 0.5 * i, 0.0, 0.05 * i));
    for (int i = 0; i < 50; i += 5) EXPECT_TRUE(oracle.addNode(node(i, i + 1)));
    std::vector<double> out;
    for (int i = 0; i < 50; ++i) {
      const register_result_t r = oracle.answer(request(i, i + 1, register_request_t::MODE_GLOBAL));
      out.push_back(r.status);
      out.push_back(r.translation[0]);
    }
    return out;
  };
  EXPECT_EQ(run(9), run(9));
  EXPECT_NE(run(9), run(10));
}

TEST(RegistrationOracle, AnswersASimulatedRunUnderTheSyntheticLoad) {
  const auto plan = RunPlan::create(testing::smallRun());
  ASSERT_TRUE(plan.ok());
  RegistrationOracle oracle(plan->options().oracle, plan->oracleSeed());
  RequestLoad load(oracle, RequestLoadOptions{});
  SessionObservers obs;
  obs.on_keyframe = [&](const KeyframeTruth& k) { load.onKeyframe(k); };
  NullSink null;
  const RunSummary run = generateRun(
      *plan, [&](int) -> MessageSink& { return null; }, obs);
  const OracleSummary& s = oracle.summary();
  EXPECT_EQ(s.keyframes, run.voKeyframes());
  EXPECT_EQ(s.nodes, load.summary().nodes_added);
  EXPECT_EQ(s.requests_node, load.summary().node_requests);
  EXPECT_EQ(s.unknown_keyframe + s.unknown_node + s.malformed + s.nodes_without_keyframe, 0);
  // Registering against the node of the robot's own cell mostly works.
  EXPECT_GT(s.ok_node, s.requests_node / 2);
}

}  // namespace
}  // namespace evermap::sim
