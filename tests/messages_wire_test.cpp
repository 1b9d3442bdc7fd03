// core/messages/wire_check.h and decodeLcm on hostile bytes, for every evermap LCM type (the
// X-macro of <evermap/all_types.hpp>: a new type is covered without a line here). The layout
// check must agree with lcm-gen's decoder on every message the decoder accepts, refuse every
// length that is not backed by bytes before anything is allocated, and never throw.
#include <gtest/gtest.h>

#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include <evermap/all_types.hpp>

#include "core/messages/convert.h"
#include "core/messages/keyframe_convert.h"
#include "core/messages/wire_check.h"
#include "tools/lcmlog/mutate.h"

namespace evermap::messages {
namespace {

template <typename Msg>
std::vector<uint8_t> encode(const Msg& m) {
  std::vector<uint8_t> b(static_cast<size_t>(m.getEncodedSize()));
  EXPECT_EQ(m.encode(b.data(), 0, static_cast<int>(b.size())), static_cast<int>(b.size()));
  return b;
}

void putBe32(std::vector<uint8_t>& b, size_t at, uint32_t v) {  // LCM is big-endian
  for (int k = 0; k < 4; ++k) b[at + k] = static_cast<uint8_t>(v >> (24 - 8 * k));
}

// Messages with every array filled, so that mutations hit lengths, strings and nested structs.
evermap::keyframe_t richKeyframe(int n) {
  evermap::keyframe_t k{};
  k.utime = 1'000'000;
  k.fx = k.fy = 400.0;
  k.cx = 320.0;
  k.cy = 240.0;
  k.baseline_m = 0.1;
  k.num_features = n;
  for (int i = 0; i < n; ++i) {
    k.keypoints.push_back({10.0f + i, 20.0f});
    k.points.push_back({0.1f, 0.2f, 2.0f});
    k.disparity.push_back(20.0f);
    k.level.push_back(0);
    k.descriptors.push_back(std::vector<uint8_t>(32, static_cast<uint8_t>(i)));
  }
  return k;
}

evermap::deputy_status_t richStatus() {
  evermap::deputy_status_t s{};
  s.utime = 5;
  s.host = "robot";
  for (const char* name : {"vo", "mapper", "loopclose"}) {
    evermap::deputy_proc_t p{};
    p.name = name;
    p.group = "slam";
    p.command = std::string("evermap-") + name + "-proc --lcm-url memq://";
    p.pid = 1234;
    s.procs.push_back(p);
  }
  s.num_procs = static_cast<int32_t>(s.procs.size());
  return s;
}

evermap::map_graph_t richGraph() {
  evermap::map_graph_t g{};
  g.utime = 9;
  for (int i = 0; i < 4; ++i) {
    evermap::map_node_t n{};
    n.node_id = i;
    n.orientation[0] = 1.0;
    g.nodes.push_back(n);
    evermap::map_edge_t e{};
    e.from_node = i;
    e.to_node = i + 1;
    g.edges.push_back(e);
  }
  g.floors.push_back(evermap::map_floor_t{0, 0.0});
  g.num_nodes = g.num_edges = 4;
  g.num_floors = 1;
  return g;
}

// Mutates `original` `trials` times (tools/lcmlog/mutate.h) and decodes each: never a throw,
// and whatever the layout accepts, the decoder decodes to the same size.
template <typename Msg>
void fuzz(const std::vector<uint8_t>& original, int trials, std::mt19937_64& rng, int* accepted) {
  for (int t = 0; t < trials; ++t) {
    const std::vector<uint8_t> b = mutateLcm(original, rng);
    const auto size = static_cast<int64_t>(b.size());
    Expected<int64_t> used = checkWire<Msg>(b.data(), size);
    Expected<Msg> msg = decodeLcm<Msg>(b.data(), size, "FUZZ");  // must not throw
    if (used && *used == size) {
      // The layout and lcm-gen agree: what the layout accepts decodes.
      Msg m;
      int n = -2;
      EXPECT_NO_THROW(n = m.decode(b.data(), 0, static_cast<int>(size))) << Msg::getTypeName();
      EXPECT_EQ(n, size) << Msg::getTypeName();
      EXPECT_TRUE(msg.ok()) << Msg::getTypeName();
      ++*accepted;
    } else {
      EXPECT_FALSE(msg.ok()) << Msg::getTypeName();
      if (!msg.ok()) {
        EXPECT_EQ(msg.error().message.find('\n'), std::string::npos);  // one line
        EXPECT_EQ(msg.error().message.rfind("FUZZ: ", 0), 0u) << msg.error().message;
      }
    }
  }
}

TEST(WireCheck, EveryTypesOwnEncodingIsAcceptedWhole) {
#define EVERMAP_CHECK_TYPE(type)                                                                 \
  {                                                                                              \
    const auto b = encode(evermap::type{});                                                      \
    auto used = checkWire<evermap::type>(b.data(), static_cast<int64_t>(b.size()));              \
    ASSERT_TRUE(used.ok()) << #type << ": " << used.error().message;                             \
    EXPECT_EQ(*used, static_cast<int64_t>(b.size())) << #type;                                   \
    EXPECT_TRUE(decodeLcm<evermap::type>(b.data(), static_cast<int64_t>(b.size()), #type).ok()); \
  }
  EVERMAP_FOR_EACH_LCM_TYPE(EVERMAP_CHECK_TYPE)
#undef EVERMAP_CHECK_TYPE
  for (const auto& b : {encode(richKeyframe(50)), encode(richStatus()), encode(richGraph())}) {
    const int64_t size = static_cast<int64_t>(b.size());
    EXPECT_TRUE(checkWire<evermap::keyframe_t>(b.data(), size).ok() ||
                checkWire<evermap::deputy_status_t>(b.data(), size).ok() ||
                checkWire<evermap::map_graph_t>(b.data(), size).ok());
  }
  const auto k = encode(richKeyframe(50));
  EXPECT_EQ(*checkWire<evermap::keyframe_t>(k.data(), static_cast<int64_t>(k.size())),
            static_cast<int64_t>(k.size()));
  const auto s = encode(richStatus());
  EXPECT_EQ(*checkWire<evermap::deputy_status_t>(s.data(), static_cast<int64_t>(s.size())),
            static_cast<int64_t>(s.size()));
  const auto g = encode(richGraph());
  EXPECT_EQ(*checkWire<evermap::map_graph_t>(g.data(), static_cast<int64_t>(g.size())),
            static_cast<int64_t>(g.size()));
}

TEST(WireCheck, AStereoCalibClaimingTwoToThe28DistortionValuesIsRefusedNamingTheMember) {
  // Issue 17: 2^28 doubles made lcm_coretypes.h's `int total_size = sizeof(int64_t) * n`
  // overflow: vo-proc resized a vector to 2 GB and read past the buffer (SIGSEGV).
  evermap::stereo_calib_t c{};
  c.utime = 1;
  c.left.body_T_cam[0] = c.right.body_T_cam[0] = 1.0;
  std::vector<uint8_t> b = encode(c);
  // hash(8) utime(8) rectified(1), then left: width height(8) fx fy cx cy(32) model(1).
  putBe32(b, 8 + 8 + 1 + 8 + 32 + 1, 1u << 28);
  const auto msg =
      decodeLcm<evermap::stereo_calib_t>(b.data(), static_cast<int64_t>(b.size()), "STEREO_CALIB");
  ASSERT_FALSE(msg.ok());
  EXPECT_NE(msg.error().message.find("STEREO_CALIB: not a valid stereo_calib_t"), std::string::npos)
      << msg.error().message;
  EXPECT_NE(msg.error().message.find("stereo_calib_t.left.distortion"), std::string::npos)
      << msg.error().message;
  EXPECT_NE(msg.error().message.find("268435456"), std::string::npos) << msg.error().message;
  // And a negative count.
  putBe32(b, 8 + 8 + 1 + 8 + 32 + 1, 0xfffffffbu);
  EXPECT_FALSE(
      decodeLcm<evermap::stereo_calib_t>(b.data(), static_cast<int64_t>(b.size()), "S").ok());
}

TEST(WireCheck, DeputyOrdersOf24To49BytesAreRefusedWithoutAThrow) {
  // Issue 17: the deputy aborted on these (std::length_error, bad_alloc).
  const uint64_t hash = static_cast<uint64_t>(evermap::deputy_order_t::getHash());
  std::mt19937 rng(5);
  for (int size = 24; size <= 49; ++size) {
    for (int fill : {0x00, 0xff, 0x7f, -1}) {
      std::vector<uint8_t> b(static_cast<size_t>(size));
      for (int k = 0; k < 8; ++k) b[k] = static_cast<uint8_t>(hash >> (56 - 8 * k));
      for (int k = 8; k < size; ++k) b[k] = static_cast<uint8_t>(fill < 0 ? rng() : fill);
      Expected<evermap::deputy_order_t> m = Error{};
      EXPECT_NO_THROW(m = decodeLcm<evermap::deputy_order_t>(b.data(), size, "DEPUTY_ORDER"));
      if (fill >= 0) {
        EXPECT_FALSE(m.ok()) << size << " bytes of " << fill;
      }
    }
  }
  // A string length of 0 (LCM writes strlen + 1): refused, naming the member.
  std::vector<uint8_t> b(24, 0);
  for (int k = 0; k < 8; ++k) b[k] = static_cast<uint8_t>(hash >> (56 - 8 * k));
  const auto m = decodeLcm<evermap::deputy_order_t>(b.data(), 24, "DEPUTY_ORDER");
  ASSERT_FALSE(m.ok());
  EXPECT_NE(m.error().message.find("deputy_order_t.host: string length 0"), std::string::npos)
      << m.error().message;
}

TEST(WireCheck, ForeignAndTruncatedBytesAreRefusedNamingTheType) {
  const auto imu = encode(evermap::imu_t{});
  const auto as_pose =
      decodeLcm<evermap::pose_t>(imu.data(), static_cast<int64_t>(imu.size()), "POSE");
  ASSERT_FALSE(as_pose.ok());
  EXPECT_NE(as_pose.error().message.find("POSE: not a valid pose_t (not a pose_t (type hash"),
            std::string::npos)
      << as_pose.error().message;
  EXPECT_FALSE(decodeLcm<evermap::imu_t>(imu.data(), 7, "IMU").ok());
  EXPECT_FALSE(
      decodeLcm<evermap::imu_t>(imu.data(), static_cast<int64_t>(imu.size()) - 1, "IMU").ok());
}

TEST(WireCheck, ATruncatedArrayOfStructsIsRefusedNamingTheElementAndTheMember) {
  // The path is spelled only on failure (issue 21: a string per member made a 56,000-node
  // MAP_GRAPH cost a million allocations); it must still name the element.
  const auto g = encode(richGraph());
  // hash(8) utime(8) num_nodes(4), then 80 bytes a node: id(8) keyframe_utime(8) ...
  const int64_t size = 8 + 8 + 4 + 2 * 80 + 10;
  const auto used = checkWire<evermap::map_graph_t>(g.data(), size);
  ASSERT_FALSE(used.ok());
  EXPECT_NE(
      used.error().message.find("map_graph_t.nodes[2].keyframe_utime: 8 bytes needed, 2 left"),
      std::string::npos)
      << used.error().message;
  // The same buffer whole: accepted (nothing of the failed walk is left behind).
  EXPECT_TRUE(checkWire<evermap::map_graph_t>(g.data(), static_cast<int64_t>(g.size())).ok());
}

TEST(WireCheck, FuzzedKeyframeNodeAddedAndRegisterRequestNeverCrashTheDecoder) {
  std::mt19937_64 rng(2017);
  int accepted = 0;
  fuzz<evermap::keyframe_t>(encode(richKeyframe(40)), 4000, rng, &accepted);
  evermap::node_added_t n{};
  n.utime = 3;
  n.node_id = 7;
  fuzz<evermap::node_added_t>(encode(n), 3000, rng, &accepted);
  evermap::register_request_t r{};
  r.utime = 4;
  r.request_id = 9;
  fuzz<evermap::register_request_t>(encode(r), 3000, rng, &accepted);
  EXPECT_GT(accepted, 0);  // flips inside values leave valid messages: both paths ran
}

TEST(WireCheck, FuzzedMessagesOfEveryTypeNeverCrashTheDecoder) {
  std::mt19937_64 rng(17);
  int accepted = 0;
#define EVERMAP_FUZZ_TYPE(type) fuzz<evermap::type>(encode(evermap::type{}), 500, rng, &accepted);
  EVERMAP_FOR_EACH_LCM_TYPE(EVERMAP_FUZZ_TYPE)
#undef EVERMAP_FUZZ_TYPE
  fuzz<evermap::deputy_status_t>(encode(richStatus()), 2000, rng, &accepted);
  fuzz<evermap::map_graph_t>(encode(richGraph()), 2000, rng, &accepted);
  EXPECT_GT(accepted, 0);
}

}  // namespace
}  // namespace evermap::messages
