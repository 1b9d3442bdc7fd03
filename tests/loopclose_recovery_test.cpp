// loopclose-proc over a lossy link: a node or a request whose KEYFRAME was lost waits while
// loopclose-proc asks vo-proc for it again (KEYFRAME_REQUEST), and the two halves wired over
// memq:// (vo-proc's side stood in for by its KeyframeResender). Keyframes are synthetic:
// each place has its own random descriptors; the registration is a test double that
// succeeds whenever both keyframes have features. The halves alone: keyframe_recovery_test.
#include <gtest/gtest.h>

#include <lcm/lcm-cpp.hpp>

#include <evermap/vo_delta_t.hpp>

#include "bow_synthetic.h"
#include "core/messages/channels.h"
#include "loopclose-proc/loop_closer.h"
#include "loopclose-proc/server.h"
#include "tests/register_results.h"
#include "tools/vocab-train/vocabulary_training.h"
#include "vo-proc/keyframe_buffer.h"

namespace evermap::loopclose {
namespace {

using bow::Descriptor;
using evermap::register_request_t;
using evermap::register_result_t;
using namespace evermap::testing;  // the status constants, kSecond, emptyKeyframe

constexpr int kPlaces = 6;
constexpr int kFeatures = 60;

class World {
 public:
  World() : rng_(7) {
    std::vector<std::vector<Descriptor>> training;
    for (int p = 0; p < kPlaces; ++p) {
      std::vector<Descriptor> d;
      for (int i = 0; i < kFeatures; ++i) d.push_back(bow::testing::randomDescriptor(rng_));
      training.push_back(d);
      places_.push_back(std::move(d));
    }
    bow::TrainingOptions o;
    o.branching = 6;
    o.levels = 3;
    vocabulary_.emplace(bow::trainVocabulary(training, o).value());
  }
  const bow::Vocabulary& vocabulary() const { return *vocabulary_; }
  evermap::keyframe_t keyframe(int place, int64_t utime) const {
    evermap::keyframe_t k = emptyKeyframe(utime);
    const std::vector<Descriptor>& d = places_[static_cast<size_t>(place)];
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
  bow::SplitMix64 rng_;
  std::vector<std::vector<Descriptor>> places_;
  std::optional<bow::Vocabulary> vocabulary_;
};

class AnyRegistration final : public FrameRegistration {
 public:
  RegistrationOutcome registerFrames(const Keyframe& target, const Keyframe& query) override {
    RegistrationOutcome o;
    o.ok = target.size() > 0 && query.size() > 0;
    o.inliers = static_cast<int>(std::min(target.size(), query.size()));
    o.covariance = 0.01 * core::Mat6::Identity();
    if (!o.ok) o.reason = "no features";
    return o;
  }
  std::string describe() const override { return "any"; }
};

evermap::node_added_t node(int64_t id, int64_t keyframe_utime, int32_t floor) {
  return nodeAdded(id, keyframe_utime, floor);
}

class LoopCloserRecoveryTest : public ::testing::Test {
 protected:
  std::unique_ptr<LoopCloser> make() {
    auto lc =
        LoopCloser::create(world_.vocabulary(), registration_, LoopCloserOptions{}, std::nullopt);
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
  AnyRegistration registration_;
};
World LoopCloserRecoveryTest::world_;

// On a lossy link a KEYFRAME (tens of fragments) is often lost for good: the node it
// describes waits while loopclose-proc asks vo-proc for it again, and is added when it comes;
// after max_attempts asks it is given up and the node rejected, naming it.
TEST_F(LoopCloserRecoveryTest, ANodeWhoseKeyframeWasLostWaitsWhileItIsAskedForAgain) {
  auto lc = make();
  const int64_t t = 100 * kSecond;
  lc->advanceClock(t);
  ASSERT_TRUE(lc->addNode(node(1, t, 0)).ok());
  lc->advanceClock(t + 100'000);
  EXPECT_TRUE(lc->takeKeyframeRequests().empty());  // it may still be on its way
  lc->advanceClock(t + 200'000);
  std::vector<evermap::keyframe_request_t> asks = lc->takeKeyframeRequests();
  ASSERT_EQ(asks.size(), 1u);
  EXPECT_EQ(asks[0].keyframe_utime, t);
  lc->advanceClock(t + 3 * kSecond);  // long past keyframe_wait_us: still waiting
  EXPECT_EQ(lc->takeKeyframeRequests().size(), 1u);
  EXPECT_TRUE(lc->takeNodeErrors().empty());
  ASSERT_TRUE(lc->addKeyframe(world_.keyframe(0, t)).ok());
  EXPECT_EQ(lc->numNodes(), 1u);
  EXPECT_EQ(lc->recoveryStats().recovered, 1);
  // Never comes: given up after max_attempts asks, the node rejected with a line naming it.
  const int64_t t2 = t + 10 * kSecond;
  ASSERT_TRUE(lc->addNode(node(2, t2, 0)).ok());
  size_t n_asks = 0;
  for (int64_t now = t2; now < t2 + 60 * kSecond; now += 100'000) {
    lc->advanceClock(now);
    n_asks += lc->takeKeyframeRequests().size();
  }
  EXPECT_EQ(n_asks, static_cast<size_t>(LoopCloserOptions{}.recovery.max_attempts));
  const std::vector<std::string> errors = lc->takeNodeErrors();
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_NE(errors[0].find("node 2"), std::string::npos) << errors[0];
  EXPECT_EQ(lc->recoveryStats().given_up, 1);
  EXPECT_EQ(lc->numNodes(), 1u);
}

TEST_F(LoopCloserRecoveryTest, ARequestWhoseKeyframeWasLostWaitsForItUpToItsAgeAndOthersGoFirst) {
  auto lc = make();
  addMap(*lc);
  const int64_t t = 100 * kSecond;
  lc->advanceClock(t);
  lc->submit(registerRequest(1, t, t, kGlobal));
  lc->advanceClock(t + 700'000);  // past keyframe_wait_us, the keyframe asked for
  EXPECT_TRUE(lc->poll().empty());
  EXPECT_EQ(lc->takeKeyframeRequests().size(), 1u);
  // A later request whose keyframe is here is answered meanwhile.
  ASSERT_TRUE(lc->addKeyframe(world_.keyframe(4, t + 800'000)).ok());
  lc->submit(registerRequest(2, t + 800'000, t + 800'000, kNode, 5));
  auto out = lc->poll();
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].request_id, 2);
  ASSERT_TRUE(lc->addKeyframe(world_.keyframe(2, t)).ok());  // the lost one, sent again
  lc->advanceClock(t + 1'400'000);
  out = lc->poll();
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].request_id, 1);
  EXPECT_EQ(out[0].status, kOk) << out[0].reason;
  EXPECT_EQ(out[0].node_id, 3);
}

TEST_F(LoopCloserRecoveryTest, ARequestAgainstANodeWhoseKeyframeIsAskedForWaitsForIt) {
  auto lc = make();
  const int64_t t = 100 * kSecond;
  lc->advanceClock(t);
  ASSERT_TRUE(lc->addNode(node(1, t, 0)).ok());  // its keyframe lost
  ASSERT_TRUE(lc->addKeyframe(world_.keyframe(0, t + 800'000)).ok());
  lc->submit(registerRequest(1, t + 800'000, t + 800'000, kNode, 1));
  EXPECT_FALSE(lc->takeKeyframeRequests().empty());
  EXPECT_TRUE(lc->poll().empty());  // not "unknown node"
  ASSERT_TRUE(lc->addKeyframe(world_.keyframe(0, t)).ok());
  const auto out = lc->poll();
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].status, kOk) << out[0].reason;
  EXPECT_EQ(out[0].node_id, 1);
}

// The two halves over LCM: loopclose-proc's server asks on KEYFRAME_REQUEST, a stand-in for
// vo-proc answers from its KeyframeResender on KEYFRAME_PART, and the first answer loses two
// of its three parts: the second ask names those two, and only they are sent again.
TEST_F(LoopCloserRecoveryTest, TheServerRecoversALostKeyframeFromVoProcsBufferOverLcm) {
  lcm::LCM lcm("memq://");
  ASSERT_TRUE(lcm.good());
  auto lc = make();
  LoopCloseServer server(lcm, *lc);
  evermap::testing::RegisterResults collected(lcm);
  vo::KeyframeResender resender(vo::KeyframeResendOptions{});
  const int64_t t = 100 * kSecond;
  const evermap::keyframe_t lost = world_.keyframe(0, t);
  resender.keep(lost);  // published once, lost on the link
  struct VoProc {
    void on(const lcm::ReceiveBuffer*, const std::string&, const evermap::keyframe_request_t* r) {
      wall_s += 1.0;
      asked.push_back(r->missing);
      const bool first = asked.size() == 1;
      for (const evermap::keyframe_part_t& p : resender->answer(*r, wall_s)) {
        if (!first || p.index == 1) lcm->publish(channels::kKeyframePart, &p);
      }
    }
    vo::KeyframeResender* resender;
    lcm::LCM* lcm;
    std::vector<std::vector<int16_t>> asked;
    double wall_s = 0.0;
  } vo_proc{&resender, &lcm, {}};
  lcm.subscribe(channels::kKeyframeRequest, &VoProc::on, &vo_proc);
  const evermap::node_added_t n = node(1, t, 0);
  for (int f = 0; f <= 60; ++f) {  // 3 s of VO at 20 Hz
    evermap::vo_delta_t d{};
    d.utime = t + f * 50'000;
    d.ref_utime = t;
    d.orientation[0] = 1.0;
    lcm.publish(channels::kVoDelta, &d);
    if (f == 3) lcm.publish(channels::kNodeAdded, &n);
    collected.deliver();
  }
  EXPECT_EQ(lc->numNodes(), 1u);
  ASSERT_EQ(vo_proc.asked.size(), 2u);
  EXPECT_TRUE(vo_proc.asked[0].empty());  // the first ask: the whole keyframe
  EXPECT_EQ(vo_proc.asked[1], (std::vector<int16_t>{0, 2}));
  EXPECT_EQ(lc->recoveryStats().asked, 1);
  EXPECT_EQ(lc->recoveryStats().asks, 2);
  EXPECT_EQ(lc->recoveryStats().recovered, 1);
  EXPECT_EQ(lc->recoveryStats().parts, 3);
  EXPECT_EQ(resender.stats().resent, 2);
  EXPECT_EQ(resender.stats().parts, 3 + 2);
  EXPECT_EQ(server.dropped(), 0);
}

// A NODE_ADDED is one datagram: 5 % of them are lost at 5 % packet loss. The mapper's
// MAP_GRAPH lists every node; one never announced is caught up from it, once.
TEST_F(LoopCloserRecoveryTest, ANodeWhoseNodeAddedWasLostIsCaughtUpFromTheMapGraph) {
  auto lc = make();
  const int64_t t = 100 * kSecond;
  for (int p = 0; p < 3; ++p) ASSERT_TRUE(lc->addKeyframe(world_.keyframe(p, t + p)).ok());
  ASSERT_TRUE(lc->addNode(node(1, t, 0)).ok());  // node 2's NODE_ADDED lost; node 3's too
  evermap::map_graph_t g{};
  g.utime = t + kSecond;
  for (int id = 1; id <= 4; ++id) {
    evermap::map_node_t n{};
    n.node_id = id;
    n.keyframe_utime = id == 4 ? t + 3 : t + id - 1;  // node 4's keyframe lost as well
    n.orientation[0] = 1.0;
    g.nodes.push_back(n);
  }
  g.num_nodes = static_cast<int32_t>(g.nodes.size());
  EXPECT_EQ(lc->catchUpNodes(g), 3);
  EXPECT_EQ(lc->numNodes(), 3u);  // 1, 2, 3; node 4 waits for its keyframe
  EXPECT_EQ(lc->stats().nodes_caught_up, 3);
  EXPECT_EQ(lc->catchUpNodes(g), 0);  // nothing twice
  ASSERT_TRUE(lc->addKeyframe(world_.keyframe(3, t + 3)).ok());
  EXPECT_EQ(lc->numNodes(), 4u);
  EXPECT_TRUE(lc->takeNodeErrors().empty());
  // A node refused once (here: an implausible floor) is not tried again.
  g.nodes.push_back(g.nodes[0]);
  g.nodes.back().node_id = 5;
  g.nodes.back().floor = -7;
  g.num_nodes = static_cast<int32_t>(g.nodes.size());
  EXPECT_EQ(lc->catchUpNodes(g), 0);
  EXPECT_EQ(lc->takeNodeErrors().size(), 1u);
  EXPECT_EQ(lc->catchUpNodes(g), 0);
  EXPECT_TRUE(lc->takeNodeErrors().empty());
}

}  // namespace
}  // namespace evermap::loopclose
