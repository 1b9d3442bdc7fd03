// tools/lcm-link/link.h: the faults of evermap-lcm-link, datagram by datagram. LCM's packets
// are made by lcmFragmentPacket (core/messages/lcm_receive_guard.h) and by hand ("LC02").
#include <gtest/gtest.h>

#include <cstdint>
#include <string>
#include <vector>

#include "core/messages/lcm_receive_guard.h"
#include "tools/lcm-link/link.h"

namespace evermap::link {
namespace {

using Bytes = std::vector<uint8_t>;

// A whole message ("LC02") on `channel`.
Bytes shortPacket(uint32_t seqno, const std::string& channel) {
  Bytes b = {0x4c,
             0x43,
             0x30,
             0x32,
             static_cast<uint8_t>(seqno >> 24),
             static_cast<uint8_t>(seqno >> 16),
             static_cast<uint8_t>(seqno >> 8),
             static_cast<uint8_t>(seqno)};
  b.insert(b.end(), channel.begin(), channel.end());
  b.push_back(0);
  b.resize(b.size() + 100, 0x55);
  return b;
}

// Message `seqno` on `channel` in `n` fragments.
std::vector<Bytes> fragments(uint32_t seqno, const std::string& channel, uint16_t n) {
  std::vector<Bytes> out;
  for (uint16_t k = 0; k < n; ++k)
    out.push_back(messages::lcmFragmentPacket(seqno, 1000u * n, 1000u * k, k, n, channel, 1000));
  return out;
}

bool admit(Direction* d, const Bytes& b, double now_s, double* leave_s = nullptr) {
  double leave = 0.0;
  const bool pass = d->admit(1, b.data(), b.size(), now_s, &leave);
  if (leave_s) *leave_s = leave;
  return pass;
}

TEST(LcmLinkHeader, NamesTheChannelOfAWholeMessageAndOfAFirstFragmentOnly) {
  const Bytes whole = shortPacket(3, "VO_DELTA");
  EXPECT_EQ(parseHeader(whole.data(), whole.size()).channel, "VO_DELTA");
  const std::vector<Bytes> f = fragments(4, "KEYFRAME", 3);
  const PacketHeader first = parseHeader(f[0].data(), f[0].size());
  EXPECT_TRUE(first.valid);
  EXPECT_EQ(first.channel, "KEYFRAME");
  EXPECT_EQ(first.fragments, 3);
  const PacketHeader second = parseHeader(f[1].data(), f[1].size());
  EXPECT_TRUE(second.valid);
  EXPECT_EQ(second.fragment, 1);
  EXPECT_EQ(second.channel, "");
  const Bytes junk = {1, 2, 3};
  EXPECT_FALSE(parseHeader(junk.data(), junk.size()).valid);
}

TEST(LcmLinkDirection, CountsEveryFragmentUnderItsMessagesChannel) {
  Direction d(LinkOptions{}, 1);
  for (const Bytes& b : fragments(9, "KEYFRAME", 4)) EXPECT_TRUE(admit(&d, b, 0.0));
  const ChannelCount& c = d.counts().at("KEYFRAME");
  EXPECT_EQ(c.datagrams, 4);
  EXPECT_EQ(c.messages, 1);
  EXPECT_EQ(c.messages_hit, 0);
  EXPECT_EQ(d.counts().count("(unknown)"), 0u);
}

TEST(LcmLinkDirection, KeepsTheLocalChannelsOnTheirHost) {
  Direction d(LinkOptions{}, 1);  // local: STEREO|RGBD
  for (const Bytes& b : fragments(1, "STEREO", 3)) EXPECT_FALSE(admit(&d, b, 0.0));
  EXPECT_TRUE(admit(&d, shortPacket(2, "STEREO_CALIB"), 0.0));
  EXPECT_EQ(d.counts().at("STEREO").local, 3);
  EXPECT_EQ(d.counts().at("STEREO").datagrams, 0);
}

TEST(LcmLinkDirection, LosesTheGivenShareOfDatagramsAndCountsEachHitMessageOnce) {
  LinkOptions o;
  o.loss_pct = 5.0;
  Direction d(o, 7);
  int passed = 0;
  for (uint32_t s = 0; s < 2000; ++s)
    for (const Bytes& b : fragments(s, "KEYFRAME", 5)) passed += admit(&d, b, 0.0);
  const ChannelCount& c = d.counts().at("KEYFRAME");
  EXPECT_EQ(c.datagrams, passed);
  EXPECT_EQ(c.datagrams + c.dropped, 10000);
  EXPECT_NEAR(c.dropped / 10000.0, 0.05, 0.01);
  // A message is lost when any of its 5 fragments is: 1 - 0.95^5 = 22.6 %.
  EXPECT_NEAR(c.messages_hit / 2000.0, 0.226, 0.03);
  EXPECT_LE(c.messages_hit, c.dropped);
}

TEST(LcmLinkDirection, LosesALargeDatagramWhenAnyOfItsIpPacketsIsLost) {
  // A 35 KB KEYFRAME is one LCM datagram but 24 IP packets at an MTU of 1500: at 5 % packet
  // loss it is lost with 1 - 0.95^24 = 71 %.
  LinkOptions o;
  o.loss_pct = 5.0;
  Direction d(o, 11);
  Bytes big = shortPacket(0, "KEYFRAME");
  big.resize(35000, 0x55);
  int lost = 0;
  for (int k = 0; k < 2000; ++k) lost += !admit(&d, big, 0.0);
  EXPECT_NEAR(lost / 2000.0, 0.708, 0.03);
}

TEST(LcmLinkDirection, TheSameSeedLosesTheSameDatagrams) {
  LinkOptions o;
  o.loss_pct = 30.0;
  Direction a(o, 3), b(o, 3);
  for (uint32_t s = 0; s < 200; ++s) {
    const Bytes p = shortPacket(s, "ATTITUDE");
    EXPECT_EQ(admit(&a, p, 0.0), admit(&b, p, 0.0));
  }
}

TEST(LcmLinkDirection, LetsNothingCrossDuringThePartition) {
  LinkOptions o;
  o.partition_start_s = 10.0;
  o.partition_s = 5.0;
  Direction d(o, 1);
  EXPECT_TRUE(admit(&d, shortPacket(1, "VO_DELTA"), 9.9));
  EXPECT_FALSE(admit(&d, shortPacket(2, "VO_DELTA"), 10.0));
  EXPECT_FALSE(admit(&d, shortPacket(3, "VO_DELTA"), 14.9));
  EXPECT_TRUE(admit(&d, shortPacket(4, "VO_DELTA"), 15.0));
  EXPECT_EQ(d.counts().at("VO_DELTA").dropped, 2);
}

TEST(LcmLinkDirection, DelaysWithJitterButKeepsTheOrder) {
  LinkOptions o;
  o.delay_ms = 50.0;
  o.jitter_ms = 20.0;
  Direction d(o, 5);
  double last = 0.0, sum = 0.0;
  for (int k = 0; k < 1000; ++k) {
    const double now = k * 0.001;  // 1000 datagrams a second: jitter would reorder them
    double leave = 0.0;
    ASSERT_TRUE(admit(&d, shortPacket(k, "POSE"), now, &leave));
    EXPECT_GE(leave, last);
    EXPECT_GE(leave, now + 0.030 - 1e-9);
    EXPECT_LE(leave, now + 0.070 + 1e-9);
    sum += leave - now;
    last = leave;
  }
  EXPECT_GT(sum / 1000.0, 0.050);  // held back by earlier, later-leaving datagrams
}

TEST(LcmLinkCounts, EndWithTheDirectionsTotal) {
  Direction d(LinkOptions{}, 1);
  admit(&d, shortPacket(1, "A"), 0.0);
  admit(&d, shortPacket(2, "B"), 0.0);
  const std::vector<std::string> lines = countLines("robot->base", d.counts());
  ASSERT_EQ(lines.size(), 3u);
  EXPECT_EQ(lines[2].rfind("robot->base total datagrams 2 bytes ", 0), 0u) << lines[2];
}

}  // namespace
}  // namespace evermap::link
