// loopclose-proc with its default frame registration (CoreRegistration = core/registration's
// registerFrames) on the real EuRoC V1_01 loop pairs (../shared/data/euroc-v101-micro/
// lcd_pairs, SOURCE.txt there), through the service path over memq://: the match images 0 and
// 2 are announced as map nodes (KEYFRAME + NODE_ADDED), the query images 1 and 3 arrive as
// keyframes and are registered on REGISTER_REQUEST, by node and by appearance search. Each
// REGISTER_RESULT must be within 5 cm and 1° of the vicon2gt ground truth (the same keyframes
// and truth as vo_euroc_test, tests/euroc_loop_pairs.h); a wrong pairing, an unknown node, a
// malformed request and keyframes without enough features come back as failures with reasons.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "core/messages/channels.h"
#include "core/messages/keyframe_convert.h"
#include "euroc_loop_pairs.h"
#include "loopclose-proc/core_registration.h"
#include "loopclose-proc/loop_closer.h"
#include "loopclose-proc/server.h"
#include "test_data.h"
#include "tests/register_results.h"
#include "tools/vocab-train/vocabulary_training.h"

namespace evermap::loopclose {
namespace {

namespace fs = std::filesystem;
using evermap::register_request_t;
using evermap::register_result_t;

using namespace evermap::testing;  // the status constants, kSecond

// A vocabulary trained here from real images of the same room that are none of the loop
// images: every 5th frame of the excerpt's stereo sequence (t = 273..278 s of V1_01), with the
// descriptors vo-proc's keyframes carry.
bow::Vocabulary trainExcerptVocabulary(const fs::path& dir, const core::StereoRectifier& r) {
  auto images = datasets::readEurocImages(dir / "mav0/cam0/data.csv");
  EXPECT_TRUE(images.ok());
  testing::KeyframeMaker maker(r);
  std::vector<std::vector<bow::Descriptor>> training;
  for (size_t i = 0; i < images->size(); i += 5) {
    const std::string name = std::to_string((*images)[i].t_ns) + ".png";
    const cv::Mat l = cv::imread((dir / "mav0/cam0/data" / name).string(), cv::IMREAD_GRAYSCALE);
    const cv::Mat rr = cv::imread((dir / "mav0/cam1/data" / name).string(), cv::IMREAD_GRAYSCALE);
    if (l.empty() || rr.empty()) continue;  // cam0/data.csv lists 4 rows without files
    std::vector<bow::Descriptor> d;
    for (const auto& o : maker.make(l, rr, static_cast<int>(i)).descriptors) {
      d.push_back(bow::descriptorFromBytes(o.data()));
    }
    training.push_back(std::move(d));
  }
  bow::TrainingOptions o;
  o.branching = 8;
  o.levels = 3;
  auto v = bow::trainVocabulary(training, o);
  EXPECT_TRUE(v.ok()) << v.error().message;
  return std::move(*v);
}

core::SE3d poseOf(const register_result_t& r) {
  const Eigen::Quaterniond q(r.orientation[0], r.orientation[1], r.orientation[2],
                             r.orientation[3]);
  return core::SE3d(core::SO3d(q),
                    core::Vec3(r.translation[0], r.translation[1], r.translation[2]));
}

TEST(LoopCloseEuroc, TheServiceRegistersTheRealLoopPairsWithinFiveCentimetresAndOneDegree) {
  EVERMAP_REQUIRE_DATA(dir, "euroc-v101-micro");
  testing::LoopPairs p = testing::loadLoopPairs(dir);
  ASSERT_EQ(p.keyframes.size(), 4u);
  const core::StereoCamera& cam = p.rectifier->camera();
  const bow::Vocabulary vocabulary = trainExcerptVocabulary(dir, *p.rectifier);
  auto registration = CoreRegistration::create(core::RegistrationOptions{});
  ASSERT_TRUE(registration.ok());
  auto lc = LoopCloser::create(vocabulary, *registration, LoopCloserOptions{}, std::nullopt);
  ASSERT_TRUE(lc.ok()) << lc.error().message;

  lcm::LCM lcm("memq://");
  ASSERT_TRUE(lcm.good());
  LoopCloseServer server(lcm, **lc);
  evermap::testing::RegisterResults collected(lcm);
  std::vector<register_result_t>& results = collected.results;
  auto deliver = [&]() { collected.deliver(); };
  // Keyframe utimes are ids here: the four images are stills from far apart in V1_01, so they
  // are given the order of Kimera's test — the match images are in the map, the queries come
  // back later (appearance search never proposes places newer than, or within 10 s of, the
  // query). The ground truth uses their real stamps.
  auto publishKeyframe = [&](const core::KeyframeFeatures& features, int64_t utime) {
    core::KeyframeFeatures f = features;
    f.utime = utime;
    const evermap::keyframe_t k = messages::toMsg(cam, f);
    lcm.publish(channels::kKeyframe, &k);
  };
  const int64_t node_of[4] = {10, -1, 12, -1};
  const int64_t utime_of[4] = {1 * kSecond, 100 * kSecond, 2 * kSecond, 101 * kSecond};
  for (int match : {0, 2}) {
    publishKeyframe(p.keyframes[static_cast<size_t>(match)], utime_of[match]);
    evermap::node_added_t n{};
    n.utime = n.keyframe_utime = utime_of[match];
    n.node_id = node_of[match];
    n.floor = 0;
    lcm.publish(channels::kNodeAdded, &n);
  }
  for (int query : {1, 3}) {
    publishKeyframe(p.keyframes[static_cast<size_t>(query)], utime_of[query]);
  }
  // A keyframe without features, and one with too few for registration (10 of query 1's).
  publishKeyframe(core::KeyframeFeatures{}, 102 * kSecond);
  core::KeyframeFeatures few = p.keyframes[1];
  few.keypoints.resize(10);
  few.points.resize(10);
  few.disparity.resize(10);
  few.levels.resize(10);
  few.descriptors.resize(10);
  publishKeyframe(few, 103 * kSecond);
  deliver();
  ASSERT_EQ((*lc)->numNodes(), 2u);
  ASSERT_EQ(server.dropped(), 0);

  // One request at a time, 1 s of data time apart (the service answers 2 per second).
  int64_t id = 0;
  auto ask = [&](int64_t keyframe, int8_t mode, int64_t target) {
    ++id;
    const register_request_t r =
        registerRequest(id, 200 * kSecond + id * kSecond, keyframe, mode, target);
    lcm.publish(channels::kRegisterRequest, &r);
    deliver();
    EXPECT_EQ(results.size(), static_cast<size_t>(id));
    if (results.size() != static_cast<size_t>(id)) return register_result_t{};
    EXPECT_EQ(results.back().request_id, id);
    return results.back();
  };
  for (const auto& [match, query] : {std::pair{0, 1}, std::pair{2, 3}}) {
    const core::SE3d truth = p.truth(match, query);  // node_T_query
    for (int8_t mode : {kNode, kGlobal}) {
      const register_result_t r = ask(utime_of[query], mode, mode == kNode ? node_of[match] : -1);
      ASSERT_EQ(r.status, kOk) << "pair (" << match << ", " << query << "): " << r.reason;
      EXPECT_EQ(r.node_id, node_of[match]);
      EXPECT_EQ(r.keyframe_utime, utime_of[query]);
      const core::SE3d err = truth.inverse() * poseOf(r);
      const double deg = core::rotationAngle(err.so3()) * 180.0 / M_PI;
      std::printf(
          "pair (%d, %d) %s: node %lld, %d inliers, score %.3f; truth %.3f m %.1f deg; "
          "error %.4f m %.3f deg\n",
          match, query, mode == kNode ? "MODE_NODE" : "MODE_GLOBAL",
          static_cast<long long>(r.node_id), r.num_inliers, r.score, truth.translation().norm(),
          core::rotationAngle(truth.so3()) * 180.0 / M_PI, err.translation().norm(), deg);
      EXPECT_LT(err.translation().norm(), 0.05);
      EXPECT_LT(deg, 1.0);
      EXPECT_GE(r.num_inliers, core::RegistrationOptions{}.min_inliers);
      for (int k = 0; k < 6; ++k) EXPECT_GT(r.covariance[7 * k], 0.0);
    }
    // The same query against the other loop's node: refused with the registration's reason.
    const int other = match == 0 ? 2 : 0;
    const register_result_t wrong = ask(utime_of[query], kNode, node_of[other]);
    EXPECT_EQ(wrong.status, kTooFewInliers);
    EXPECT_FALSE(wrong.reason.empty());
    std::printf("query %d against node %lld: %s\n", query, static_cast<long long>(node_of[other]),
                wrong.reason.c_str());
  }
  register_result_t r = ask(utime_of[1], kNode, 999);
  EXPECT_EQ(r.status, kUnknownNode);
  EXPECT_NE(r.reason.find("999"), std::string::npos) << r.reason;
  r = ask(utime_of[1], 7, 10);
  EXPECT_EQ(r.status, kMalformed);
  EXPECT_NE(r.reason.find("mode 7"), std::string::npos) << r.reason;
  r = ask(102 * kSecond, kNode, 10);
  EXPECT_EQ(r.status, kTooFewInliers);
  EXPECT_NE(r.reason.find("no features"), std::string::npos) << r.reason;
  r = ask(103 * kSecond, kNode, 10);
  EXPECT_EQ(r.status, kTooFewInliers);
  EXPECT_NE(r.reason.find("insufficient features"), std::string::npos) << r.reason;
  EXPECT_EQ(server.published(), id);
}

}  // namespace
}  // namespace evermap::loopclose
