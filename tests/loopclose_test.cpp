// loopclose-proc: node bookkeeping, the two request modes, failure answers with reasons, the
// 2 Hz newest-first schedule with stale requests, persistence in the map store across
// sessions, and the LCM wiring over memq://. Keyframes are synthetic: each "place" has its own
// 80 random descriptors, and a keyframe of a place shows them with a few bits of noise. The
// frame registration is a test double (the real one comes from core/, vo branch): it succeeds
// when enough descriptors match index by index and returns a pose that encodes the pair.
#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>

#include <lcm/lcm-cpp.hpp>

#include <evermap/vo_delta_t.hpp>

#include "bow_synthetic.h"
#include "core/messages/channels.h"
#include "loopclose-proc/loop_closer.h"
#include "loopclose-proc/server.h"
#include "tests/register_results.h"
#include "tools/vocab-train/vocabulary_training.h"

namespace evermap::loopclose {
namespace {

using bow::Descriptor;
using bow::SplitMix64;
using evermap::register_request_t;
using evermap::register_result_t;

using namespace evermap::testing;  // the status constants, kSecond, emptyKeyframe

constexpr int kPlaces = 8;
constexpr int kFeatures = 80;

class World {
 public:
  World() : rng_(99) {
    for (int p = 0; p < kPlaces; ++p) {
      std::vector<Descriptor> prototypes;
      for (int i = 0; i < kFeatures; ++i)
        prototypes.push_back(bow::testing::randomDescriptor(rng_));
      places_.push_back(std::move(prototypes));
    }
    std::vector<std::vector<Descriptor>> training;
    for (int copy = 0; copy < 3; ++copy) {
      for (int p = 0; p < kPlaces; ++p) training.push_back(noisy(p));
    }
    bow::TrainingOptions o;
    o.branching = 8;
    o.levels = 3;
    vocabulary_.emplace(bow::trainVocabulary(training, o).value());
  }
  const bow::Vocabulary& vocabulary() const { return *vocabulary_; }

  std::vector<Descriptor> noisy(int place) {
    std::vector<Descriptor> d;
    for (const Descriptor& p : places_[static_cast<size_t>(place)]) {
      d.push_back(bow::testing::flipBits(p, 6, rng_));
    }
    return d;
  }
  evermap::keyframe_t keyframe(int place, int64_t utime) {
    evermap::keyframe_t k = emptyKeyframe(utime);
    const std::vector<Descriptor> d = place >= 0 ? noisy(place) : std::vector<Descriptor>{};
    k.num_features = static_cast<int32_t>(d.size());
    for (size_t i = 0; i < d.size(); ++i) {
      k.keypoints.push_back({static_cast<float>(4 * i), 100.0f});
      k.points.push_back({0.1f * static_cast<float>(i), 0.0f, 3.0f});
      k.disparity.push_back(16.5f);
      k.level.push_back(0);
      k.descriptors.emplace_back(d[i].bytes.begin(), d[i].bytes.end());
    }
    return k;
  }

 private:
  SplitMix64 rng_;
  std::vector<std::vector<Descriptor>> places_;
  std::optional<bow::Vocabulary> vocabulary_;
};

// Succeeds when >= 40 descriptors match index by index within 20 bits; the pose returned is a
// translation of (target utime - query utime) seconds along x, so a test can tell the pair.
class FakeRegistration final : public FrameRegistration {
 public:
  RegistrationOutcome registerFrames(const Keyframe& target, const Keyframe& query) override {
    ++calls;
    RegistrationOutcome o;
    const size_t n = std::min(target.size(), query.size());
    for (size_t i = 0; i < n; ++i) {
      o.inliers += core::hammingDistance(target.features.descriptors[i],
                                         query.features.descriptors[i]) <= 20;
    }
    if (o.inliers < 40) {
      o.reason = std::to_string(o.inliers) + " inliers";
      return o;
    }
    o.ok = true;
    o.target_T_query =
        core::SE3d(core::SO3d(), core::Vec3(1e-6 * (target.utime() - query.utime()), 0, 0));
    o.covariance = 0.01 * core::Mat6::Identity();
    return o;
  }
  std::string describe() const override { return "fake"; }
  int calls = 0;
};

using evermap::testing::registerRequest;
evermap::node_added_t node(int64_t id, int64_t keyframe_utime, int32_t floor) {
  return evermap::testing::nodeAdded(id, keyframe_utime, floor);
}

// Without asking vo-proc again for missed keyframes: the plain wait of keyframe_wait_us.
LoopCloserOptions noRecovery() {
  LoopCloserOptions o;
  o.recovery.max_attempts = 0;
  return o;
}

class LoopCloserTest : public ::testing::Test {
 protected:
  std::unique_ptr<LoopCloser> make(LoopCloserOptions o = {},
                                   std::optional<bow::PlaceStore> store = std::nullopt) {
    auto lc = LoopCloser::create(world_.vocabulary(), registration_, o, std::move(store));
    EXPECT_TRUE(lc.ok());
    return std::move(*lc);
  }
  // Nodes 1..kPlaces: place p - 1 seen at second p on floor 0.
  void addMap(LoopCloser& lc) {
    for (int p = 0; p < kPlaces; ++p) {
      const int64_t t = (p + 1) * kSecond;
      ASSERT_TRUE(lc.addKeyframe(world_.keyframe(p, t)).ok());
      ASSERT_TRUE(lc.addNode(node(p + 1, t, 0)).ok());
    }
  }
  static World world_;
  FakeRegistration registration_;
};
World LoopCloserTest::world_;

TEST_F(LoopCloserTest, NodeModeRegistersAgainstTheGivenNode) {
  auto lc = make();
  addMap(*lc);
  EXPECT_EQ(lc->numNodes(), static_cast<size_t>(kPlaces));
  const int64_t t = 60 * kSecond;
  ASSERT_TRUE(lc->addKeyframe(world_.keyframe(2, t)).ok());  // back at place 2 = node 3
  register_result_t r = lc->answer(registerRequest(7, t, t, kNode, 3));
  EXPECT_EQ(r.status, kOk) << r.reason;
  EXPECT_EQ(r.request_id, 7);
  EXPECT_EQ(r.keyframe_utime, t);
  EXPECT_EQ(r.node_id, 3);
  EXPECT_NEAR(r.translation[0], 3.0 - 60.0, 1e-9);
  EXPECT_DOUBLE_EQ(r.orientation[0], 1.0);
  EXPECT_DOUBLE_EQ(r.covariance[0], 0.01);
  EXPECT_DOUBLE_EQ(r.covariance[7], 0.01);
  EXPECT_DOUBLE_EQ(r.covariance[1], 0.0);
  EXPECT_GE(r.num_inliers, 40);
  EXPECT_GT(r.score, 0.3);
  // Against another place: registration fails, and the answer says why.
  r = lc->answer(registerRequest(8, t, t, kNode, 5));
  EXPECT_EQ(r.status, kTooFewInliers);
  EXPECT_NE(r.reason.find("inliers"), std::string::npos) << r.reason;
  EXPECT_EQ(r.node_id, 5);
}

TEST_F(LoopCloserTest, GlobalModeFindsTheRevisitedPlaceOnTheRequestedFloor) {
  auto lc = make();
  addMap(*lc);
  // Place 5 also seen on floor 1 (node 100) — as if two floors looked alike.
  ASSERT_TRUE(lc->addKeyframe(world_.keyframe(5, 20 * kSecond)).ok());
  ASSERT_TRUE(lc->addNode(node(100, 20 * kSecond, 1)).ok());
  const int64_t t = 60 * kSecond;
  ASSERT_TRUE(lc->addKeyframe(world_.keyframe(5, t)).ok());
  register_result_t r = lc->answer(registerRequest(1, t, t, kGlobal, -1, 0));
  EXPECT_EQ(r.status, kOk) << r.reason;
  EXPECT_EQ(r.node_id, 6);
  EXPECT_GT(r.score, 0.3);
  r = lc->answer(registerRequest(2, t, t, kGlobal, -1, 1));
  EXPECT_EQ(r.status, kOk) << r.reason;
  EXPECT_EQ(r.node_id, 100);
  r = lc->answer(registerRequest(3, t, t, kGlobal, -1, 4));
  EXPECT_EQ(r.status, kNoCandidate);
  EXPECT_NE(r.reason.find("floor 4"), std::string::npos) << r.reason;
}

TEST_F(LoopCloserTest, RecentPlacesAreNotLoopClosures) {
  LoopCloserOptions o;
  o.exclude_recent_us = 10 * kSecond;
  auto lc = make(o);
  ASSERT_TRUE(lc->addKeyframe(world_.keyframe(1, 1 * kSecond)).ok());
  ASSERT_TRUE(lc->addNode(node(1, 1 * kSecond, 0)).ok());
  const int64_t t = 5 * kSecond;  // 4 s later, same place: not a loop yet
  ASSERT_TRUE(lc->addKeyframe(world_.keyframe(1, t)).ok());
  register_result_t r = lc->answer(registerRequest(1, t, t, kGlobal));
  EXPECT_EQ(r.status, kNoCandidate) << r.reason;
  const int64_t later = 30 * kSecond;
  ASSERT_TRUE(lc->addKeyframe(world_.keyframe(1, later)).ok());
  r = lc->answer(registerRequest(2, later, later, kGlobal));
  EXPECT_EQ(r.status, kOk) << r.reason;
}

TEST_F(LoopCloserTest, BadInputIsAnsweredWithAReasonNeverACrash) {
  auto lc = make(noRecovery());
  addMap(*lc);
  const int64_t t = 60 * kSecond;
  ASSERT_TRUE(lc->addKeyframe(world_.keyframe(2, t)).ok());
  register_result_t r = lc->answer(registerRequest(1, t, t, kNode, 999));
  EXPECT_EQ(r.status, kUnknownNode);
  EXPECT_NE(r.reason.find("999"), std::string::npos);
  r = lc->answer(registerRequest(2, t, t + 1, kNode, 3));
  EXPECT_EQ(r.status, kUnknownKeyframe);
  r = lc->answer(registerRequest(3, t, t, 7, 3));
  EXPECT_EQ(r.status, kMalformed);
  EXPECT_NE(r.reason.find("mode 7"), std::string::npos);
  // An empty keyframe is accepted as data but answered with a reason when used.
  ASSERT_TRUE(lc->addKeyframe(world_.keyframe(-1, t + 10)).ok());
  r = lc->answer(registerRequest(4, t, t + 10, kGlobal));
  EXPECT_EQ(r.status, kTooFewInliers);
  EXPECT_NE(r.reason.find("no features"), std::string::npos);
  ASSERT_TRUE(lc->addNode(node(50, t + 10, 0)).ok());
  r = lc->answer(registerRequest(5, t, t, kNode, 50));
  EXPECT_EQ(r.status, kTooFewInliers);
  EXPECT_NE(r.reason.find("no features"), std::string::npos) << r.reason;
  // Malformed keyframes and nodes are refused and counted.
  evermap::keyframe_t bad = world_.keyframe(1, t + 20);
  bad.num_features = 3;
  EXPECT_FALSE(lc->addKeyframe(bad).ok());
  bad = world_.keyframe(1, t + 20);
  bad.points[4][1] = std::nanf("");
  EXPECT_FALSE(lc->addKeyframe(bad).ok());
  bad = world_.keyframe(1, t + 20);
  bad.fx = 0;
  EXPECT_FALSE(lc->addKeyframe(bad).ok());
  EXPECT_EQ(lc->stats().keyframes_rejected, 3);
  EXPECT_FALSE(lc->addNode(node(60, 12345, 0)).ok());  // keyframe never seen
  EXPECT_FALSE(lc->addNode(node(3, t, 0)).ok());       // id already used
  EXPECT_EQ(lc->stats().nodes_rejected, 2);
  EXPECT_EQ(lc->stats().failed, 5);
}

TEST_F(LoopCloserTest, AnswersAtMostTwoPerSecondNewestFirstAndDropsStaleOnes) {
  auto lc = make();
  addMap(*lc);
  const int64_t t = 100 * kSecond;
  for (int k = 0; k < 3; ++k) {
    ASSERT_TRUE(lc->addKeyframe(world_.keyframe(k, t + k * 100'000)).ok());
  }
  lc->submit(registerRequest(1, t, t, kNode, 1));
  lc->submit(registerRequest(2, t + 100'000, t + 100'000, kNode, 2));
  lc->submit(registerRequest(3, t + 200'000, t + 200'000, kNode, 3));
  auto out = lc->poll();
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].request_id, 3);  // the newest
  EXPECT_EQ(out[0].status, kOk) << out[0].reason;
  ASSERT_TRUE(lc->addKeyframe(world_.keyframe(4, t + 500'000)).ok());  // 0.3 s after: not due
  EXPECT_TRUE(lc->poll().empty());
  ASSERT_TRUE(lc->addKeyframe(world_.keyframe(4, t + 700'000)).ok());  // 0.5 s after
  out = lc->poll();
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].request_id, 2);
  EXPECT_EQ(lc->pending(), 1u);
  // Request 1 has now waited 2.5 s of data time since it arrived: stale, answered so and counted.
  ASSERT_TRUE(lc->addKeyframe(world_.keyframe(4, t + 2'500'000)).ok());
  out = lc->poll();
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].request_id, 1);
  EXPECT_EQ(out[0].status, kStale);
  EXPECT_NE(out[0].reason.find("stale"), std::string::npos);
  EXPECT_EQ(lc->stats().stale, 1);
  EXPECT_EQ(lc->pending(), 0u);
}

// A burst (vo-proc's start-up hold releases 3 s of frames at once): the mapper's request on the
// burst's first keyframe arrives 3 s behind the newest data. Its age counts from its arrival:
// it is answered, and goes stale only after waiting 2 s of data time here.
TEST_F(LoopCloserTest, ARequestsAgeCountsFromItsArrivalNotItsStamp) {
  auto lc = make();
  addMap(*lc);
  const int64_t t = 100 * kSecond;
  ASSERT_TRUE(lc->addKeyframe(world_.keyframe(0, t)).ok());
  lc->advanceClock(t + 3 * kSecond);  // the rest of the burst
  lc->submit(registerRequest(1, t, t, kNode, 1));
  auto out = lc->poll();
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].status, kOk) << out[0].reason;
  EXPECT_EQ(lc->stats().stale, 0);
  // A request of the same burst for a keyframe that never comes (asked of vo-proc again
  // meanwhile): it waits, and is stale 2 s of data time after it arrived.
  lc->submit(registerRequest(2, t, t + 100'000, kNode, 1));
  for (const int64_t waited_us : {0, 1'000'000, 1'900'000, 2'100'000}) {
    lc->advanceClock(t + 3 * kSecond + waited_us);
    out = lc->poll();
    if (waited_us < 2 * kSecond) {
      EXPECT_TRUE(out.empty()) << "after " << waited_us << " us";
    }
  }
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].status, kStale);
  EXPECT_NE(out[0].reason.find("waited 2.100 s"), std::string::npos) << out[0].reason;
  // Without asking vo-proc again: a request of a burst whose keyframe is still on its way waits
  // keyframe_wait_us from its arrival for it, not from its stamp.
  auto plain = make(noRecovery());
  addMap(*plain);
  const int64_t t2 = 200 * kSecond;
  plain->advanceClock(t2 + 3 * kSecond);
  plain->submit(registerRequest(3, t2, t2, kNode, 1));
  plain->advanceClock(t2 + 3'300'000);
  EXPECT_TRUE(plain->poll().empty());
  ASSERT_TRUE(plain->addKeyframe(world_.keyframe(0, t2)).ok());
  out = plain->poll();
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].status, kOk) << out[0].reason;
}

// Live, the mapper's request (sent on the frame's VO_DELTA) often overtakes the frame's
// KEYFRAME (tens of UDP fragments): it waits for it, for keyframe_wait_us of data time.
TEST_F(LoopCloserTest, ARequestThatOvertookItsKeyframeWaitsForIt) {
  auto lc = make(noRecovery());
  addMap(*lc);
  const int64_t t = 100 * kSecond;
  lc->advanceClock(t);
  lc->submit(registerRequest(1, t, t, kGlobal));
  EXPECT_TRUE(lc->poll().empty());  // not answered "unknown keyframe"
  lc->advanceClock(t + 50'000);
  EXPECT_TRUE(lc->poll().empty());
  ASSERT_TRUE(lc->addKeyframe(world_.keyframe(2, t)).ok());
  auto out = lc->poll();
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].request_id, 1);
  EXPECT_EQ(out[0].status, kOk) << out[0].reason;
  EXPECT_EQ(out[0].node_id, 3);
  // A keyframe that never comes: answered unknown once the wait is over, not before.
  const int64_t t2 = t + 2 * kSecond;
  lc->submit(registerRequest(2, t2, t2, kGlobal));
  lc->advanceClock(t2 + 400'000);
  EXPECT_TRUE(lc->poll().empty());
  lc->advanceClock(t2 + 500'000);
  out = lc->poll();
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].request_id, 2);
  EXPECT_EQ(out[0].status, kUnknownKeyframe);
}

// The mapper makes its first node on the first keyframe's VO_DELTA: its NODE_ADDED (small)
// can come before the KEYFRAME (tens of fragments). Rejected, that place was never in the
// database, and a later session starting there could not be placed. It waits instead.
TEST_F(LoopCloserTest, ANodeThatCameBeforeItsKeyframeWaitsForIt) {
  auto lc = make(noRecovery());
  const int64_t t = 100 * kSecond;
  lc->advanceClock(t);
  ASSERT_TRUE(lc->addNode(node(1, t, 0)).ok());
  EXPECT_EQ(lc->numNodes(), 0u);
  EXPECT_EQ(lc->stats().nodes_waited, 1);
  lc->advanceClock(t + 100'000);
  ASSERT_TRUE(lc->addKeyframe(world_.keyframe(0, t)).ok());
  EXPECT_EQ(lc->numNodes(), 1u);
  EXPECT_EQ(lc->stats().nodes, 1);
  EXPECT_TRUE(lc->takeNodeErrors().empty());
  // Found by a later query of the same place.
  ASSERT_TRUE(lc->addKeyframe(world_.keyframe(0, t + 20 * kSecond)).ok());
  const register_result_t r =
      lc->answer(registerRequest(1, t + 20 * kSecond, t + 20 * kSecond, kGlobal));
  EXPECT_EQ(r.status, kOk) << r.reason;
  EXPECT_EQ(r.node_id, 1);
  // A keyframe that never comes: rejected once the wait is over, with a line naming the node.
  const int64_t t2 = t + 30 * kSecond;
  ASSERT_TRUE(lc->addNode(node(2, t2, 0)).ok());
  EXPECT_FALSE(lc->addNode(node(2, t2, 0)).ok());  // the same node again: not queued twice
  lc->advanceClock(t2 + 400'000);
  EXPECT_TRUE(lc->takeNodeErrors().empty());
  lc->advanceClock(t2 + 500'000);
  const std::vector<std::string> errors = lc->takeNodeErrors();
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_NE(errors[0].find("node 2"), std::string::npos) << errors[0];
  EXPECT_EQ(lc->stats().nodes_rejected, 2);
  EXPECT_EQ(lc->numNodes(), 1u);
}

TEST_F(LoopCloserTest, NodesNoMapperWouldSendAreRefusedAndLeaveTheMapAndTheClockAsTheyWere) {
  auto lc = make();
  addMap(*lc);
  const int64_t t = 60 * kSecond;
  ASSERT_TRUE(lc->addKeyframe(world_.keyframe(2, t)).ok());
  const int64_t now = lc->now();
  struct Case {
    evermap::node_added_t msg;
    const char* named;
  };
  evermap::node_added_t negative_id = node(-4, t, 0);
  evermap::node_added_t high_floor = node(20, t, 1000);
  evermap::node_added_t negative_floor = node(21, t, -2);  // -1: a floor the mapper could not label
  evermap::node_added_t negative_session = node(22, t, 0);
  negative_session.session = -1;
  evermap::node_added_t before_keyframe = node(23, t, 0);
  before_keyframe.utime = t - 1;  // a node is made on its keyframe's frame, never before
  evermap::node_added_t far_ahead = node(24, t, 0);
  far_ahead.utime = t + 30 * kSecond;  // would move the clock if it were looked at first
  far_ahead.keyframe_utime = t + 40 * kSecond;
  for (const Case& c : {Case{negative_id, "node id -4"}, Case{high_floor, "max_floor 999"},
                        Case{negative_floor, "floor -2"}, Case{negative_session, "session -1"},
                        Case{before_keyframe, "after the node's stamp"},
                        Case{far_ahead, "after the node's stamp"}}) {
    const Status s = lc->addNode(c.msg);
    ASSERT_FALSE(s.ok()) << c.named;
    EXPECT_NE(s.error().message.find(c.named), std::string::npos) << s.error().message;
  }
  EXPECT_EQ(lc->stats().nodes_implausible, 6);
  EXPECT_EQ(lc->stats().nodes_rejected, 6);
  EXPECT_EQ(lc->numNodes(), static_cast<size_t>(kPlaces));
  EXPECT_EQ(lc->stats().nodes_waited, 0);
  EXPECT_EQ(lc->now(), now);
  // The same keyframe as a plausible node: added.
  ASSERT_TRUE(lc->addNode(node(20, t, 999)).ok());
  EXPECT_EQ(lc->numNodes(), static_cast<size_t>(kPlaces) + 1);
}

TEST_F(LoopCloserTest, TheMapHoldsAtMostMaxPlacesAndAtMostMaxWaitingNodesWait) {
  LoopCloserOptions o;
  o.max_places = 5;
  o.max_waiting_nodes = 2;
  auto lc = make(o);
  const int64_t t0 = 100 * kSecond;
  for (int p = 0; p < 5; ++p) {
    ASSERT_TRUE(lc->addKeyframe(world_.keyframe(p, t0 + p)).ok());
    ASSERT_TRUE(lc->addNode(node(p + 1, t0 + p, 0)).ok());
  }
  ASSERT_TRUE(lc->addKeyframe(world_.keyframe(5, t0 + 5)).ok());
  const Status full = lc->addNode(node(6, t0 + 5, 0));
  ASSERT_FALSE(full.ok());
  EXPECT_NE(full.error().message.find("max_places = 5"), std::string::npos) << full.error().message;
  EXPECT_EQ(lc->numNodes(), 5u);
  EXPECT_EQ(lc->stats().nodes_over_capacity, 1);
  // The places held still answer.
  ASSERT_TRUE(lc->addKeyframe(world_.keyframe(1, t0 + 6)).ok());
  const register_result_t r = lc->answer(registerRequest(1, t0 + 6, t0 + 6, kNode, 2));
  EXPECT_EQ(r.status, kOk) << r.reason;

  LoopCloserOptions w;
  w.max_waiting_nodes = 2;
  auto waiting = make(w);
  const int64_t t = 200 * kSecond;
  waiting->advanceClock(t);
  ASSERT_TRUE(waiting->addNode(node(1, t + 1, 0)).ok());
  ASSERT_TRUE(waiting->addNode(node(2, t + 2, 0)).ok());
  const Status third = waiting->addNode(node(3, t + 3, 0));
  ASSERT_FALSE(third.ok());
  EXPECT_NE(third.error().message.find("max_waiting_nodes = 2"), std::string::npos)
      << third.error().message;
  EXPECT_EQ(waiting->stats().nodes_waited, 2);
  EXPECT_EQ(waiting->stats().nodes_over_capacity, 1);
  // The two that wait are added when their keyframes come.
  ASSERT_TRUE(waiting->addKeyframe(world_.keyframe(0, t + 1)).ok());
  ASSERT_TRUE(waiting->addKeyframe(world_.keyframe(1, t + 2)).ok());
  EXPECT_EQ(waiting->numNodes(), 2u);
  LoopCloserOptions bad;
  bad.max_places = 0;
  EXPECT_FALSE(bad.validate().ok());
  bad = LoopCloserOptions{};
  bad.max_waiting_nodes = 0;
  EXPECT_FALSE(bad.validate().ok());
}

TEST_F(LoopCloserTest, AWaitingNodeStampedAheadDoesNotHoldTheOthersBehindIt) {
  auto lc = make(noRecovery());
  const int64_t t = 100 * kSecond;
  lc->advanceClock(t);
  ASSERT_TRUE(lc->addNode(node(1, t + 400'000, 0)).ok());  // arrived first, stamped ahead
  ASSERT_TRUE(lc->addNode(node(2, t, 0)).ok());
  lc->advanceClock(t + 500'000);  // node 2's wait is over, node 1's is not
  const std::vector<std::string> errors = lc->takeNodeErrors();
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_NE(errors[0].find("node 2"), std::string::npos) << errors[0];
  ASSERT_TRUE(lc->addKeyframe(world_.keyframe(0, t + 400'000)).ok());
  EXPECT_EQ(lc->numNodes(), 1u);
  EXPECT_TRUE(lc->takeNodeErrors().empty());
}

TEST_F(LoopCloserTest, AFullQueueDropsTheOldestRequest) {
  LoopCloserOptions o;
  o.max_pending_requests = 2;
  auto lc = make(o);
  addMap(*lc);
  const int64_t t = 100 * kSecond;
  ASSERT_TRUE(lc->addKeyframe(world_.keyframe(0, t)).ok());
  for (int k = 1; k <= 3; ++k) lc->submit(registerRequest(k, t + k, t, kNode, 1));
  auto out = lc->poll();
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[0].request_id, 1);
  EXPECT_EQ(out[0].status, kStale);
  EXPECT_EQ(out[1].request_id, 3);
  EXPECT_EQ(out[1].status, kOk);
  EXPECT_EQ(lc->stats().requests, 3);
}

TEST_F(LoopCloserTest, TheMapStoreCarriesNodesAndKeyframesToTheNextSession) {
  const auto dir =
      std::filesystem::temp_directory_path() / ("evermap_loopclose_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const auto file = dir / "map.db";
  const bow::Vocabulary& v = world_.vocabulary();
  LoopCloserOptions o;
  o.node_keyframe_cache = 2;  // most node keyframes must come back from the store
  {
    auto store = bow::PlaceStore::open(file, v.fingerprint(), v.numWords());
    ASSERT_TRUE(store.ok()) << store.error().message;
    auto lc = make(o, std::move(*store));
    addMap(*lc);
    EXPECT_EQ(lc->stats().store_errors, 0);
  }
  auto store = bow::PlaceStore::open(file, v.fingerprint(), v.numWords());
  ASSERT_TRUE(store.ok());
  auto lc = make(o, std::move(*store));
  EXPECT_EQ(lc->numNodes(), static_cast<size_t>(kPlaces));
  const int64_t t = 200 * kSecond;
  ASSERT_TRUE(lc->addKeyframe(world_.keyframe(1, t)).ok());
  register_result_t r = lc->answer(registerRequest(1, t, t, kNode, 2));
  EXPECT_EQ(r.status, kOk) << r.reason;
  for (int p : {6, 0, 3}) {
    ASSERT_TRUE(lc->addKeyframe(world_.keyframe(p, t + p + 1)).ok());
    r = lc->answer(registerRequest(2, t, t + p + 1, kGlobal));
    EXPECT_EQ(r.status, kOk) << r.reason;
    EXPECT_EQ(r.node_id, p + 1);
  }
  std::filesystem::remove_all(dir);
}

// Localization (a read-only store): every stored place is a candidate, whatever its time (a
// query 2 s after place 7, one before every place), and the answer is stamped with the
// stream's clock, not the map's; mapping excludes the recent place.
TEST_F(LoopCloserTest, AReadOnlyStoreExcludesNoPlaceByTime) {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("evermap_loopclose_ro_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const auto file = dir / "map.db";
  const bow::Vocabulary& v = world_.vocabulary();
  // The map: places 0..7 at 1..8 s, stored.
  addMap(*make({}, bow::PlaceStore::open(file, v.fingerprint(), v.numWords()).value()));
  auto query = [&](LoopCloser& lc, int place, int64_t t) {
    EXPECT_TRUE(lc.addKeyframe(world_.keyframe(place, t)).ok());
    return lc.answer(registerRequest(1, t, t, kGlobal));
  };
  for (const auto& [place, t] : {std::pair<int, int64_t>{7, 10 * kSecond}, {2, kSecond / 2}}) {
    auto store = bow::PlaceStore::openReadOnly(file, v.fingerprint(), v.numWords());
    ASSERT_TRUE(store.ok()) << store.error().message;
    EXPECT_TRUE(store->readOnly());
    auto lc = make({}, std::move(*store));
    const register_result_t r = query(*lc, place, t);
    EXPECT_EQ(r.status, kOk) << r.reason;
    EXPECT_EQ(r.node_id, place + 1);
    EXPECT_LE(r.utime, t) << "answered from the map's clock";
  }
  auto store = bow::PlaceStore::open(file, v.fingerprint(), v.numWords());
  ASSERT_TRUE(store.ok());
  EXPECT_FALSE(store->readOnly());
  auto lc = make({}, std::move(*store));
  EXPECT_EQ(query(*lc, 7, 10 * kSecond).status, kNoCandidate);  // mapping: 10 s excluded
  std::filesystem::remove_all(dir);
}

TEST_F(LoopCloserTest, ServesRequestsOverLcm) {
  lcm::LCM lcm("memq://");
  ASSERT_TRUE(lcm.good());
  auto lc = make();
  LoopCloseServer server(lcm, *lc);
  evermap::testing::RegisterResults collected(lcm);
  std::vector<register_result_t>& results = collected.results;
  auto deliver = [&]() { collected.deliver(); };
  for (int p = 0; p < 3; ++p) {
    const evermap::keyframe_t k = world_.keyframe(p, (p + 1) * kSecond);
    lcm.publish(channels::kKeyframe, &k);
    const evermap::node_added_t n = node(p + 1, (p + 1) * kSecond, 0);
    lcm.publish(channels::kNodeAdded, &n);
  }
  deliver();
  EXPECT_EQ(lc->numNodes(), 3u);
  const evermap::keyframe_t q = world_.keyframe(1, 50 * kSecond);
  lcm.publish(channels::kKeyframe, &q);
  const register_request_t req = registerRequest(42, 50 * kSecond, 50 * kSecond, kGlobal, -1, 0);
  lcm.publish(channels::kRegisterRequest, &req);
  // Garbage on every input channel: counted, never fatal.
  const char junk[] = "not an lcm message";
  for (const char* ch : {channels::kKeyframe, channels::kNodeAdded, channels::kRegisterRequest}) {
    lcm.publish(ch, junk, sizeof(junk));
  }
  deliver();
  ASSERT_EQ(results.size(), 1u);
  EXPECT_EQ(results[0].request_id, 42);
  EXPECT_EQ(results[0].status, kOk) << results[0].reason;
  EXPECT_EQ(results[0].node_id, 2);
  EXPECT_EQ(server.dropped(), 3);
  EXPECT_EQ(server.published(), 1);
}

// Live, a session's first request must not wait for the time guard's clock: keyframes and
// requests come about once a second and the guard wants three distinct stamps that agree.
// VO_DELTA (20-30 Hz) starts the clock within three frames.
TEST_F(LoopCloserTest, TheMotionStreamStartsTheClockSoTheFirstRequestIsAnsweredAtOnce) {
  for (bool with_vo : {false, true}) {
    SCOPED_TRACE(with_vo ? "with VO_DELTA" : "without VO_DELTA");
    lcm::LCM lcm("memq://");
    ASSERT_TRUE(lcm.good());
    auto lc = make();
    addMap(*lc);
    LoopCloseServer server(lcm, *lc);
    evermap::testing::RegisterResults collected(lcm);
    std::vector<register_result_t>& results = collected.results;
    auto deliver = [&]() { collected.deliver(); };
    const int64_t t = 100 * kSecond;  // far from the clock addMap left: the guard holds
    const evermap::keyframe_t k = world_.keyframe(1, t);
    lcm.publish(channels::kKeyframe, &k);
    const register_request_t req = registerRequest(7, t, t, kGlobal, -1, 0);
    lcm.publish(channels::kRegisterRequest, &req);
    for (int f = 1; with_vo && f <= 3; ++f) {  // 50 ms apart: one keyframe interval is not over
      evermap::vo_delta_t d{};
      d.utime = t + f * 50'000;
      d.ref_utime = t;
      d.orientation[0] = 1.0;
      lcm.publish(channels::kVoDelta, &d);
    }
    deliver();
    if (!with_vo) {
      // Keyframe and request alone (one stamp): the guard holds them, nothing is answered.
      EXPECT_TRUE(results.empty());
      continue;
    }
    ASSERT_EQ(results.size(), 1u);
    EXPECT_EQ(results[0].request_id, 7);
    EXPECT_EQ(results[0].status, kOk) << results[0].reason;
    EXPECT_EQ(results[0].node_id, 2);
    EXPECT_EQ(server.dropped(), 0);
  }
}

}  // namespace
}  // namespace evermap::loopclose
