// core/messages/envelope.h, sender_check.h and outbox.h (issue 47): the trailer round trip, a
// tampered byte, a wrong key, a replay, a second sender, a lock released after silence, the key
// file's rules; and, over memq://, an Inbox that refuses what a keyless sender publishes.
#include <gtest/gtest.h>

#include <sys/stat.h>

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include <evermap/imu_t.hpp>

#include "core/messages/channels.h"
#include "core/messages/envelope.h"
#include "core/messages/inbox.h"
#include "core/messages/outbox.h"
#include "core/messages/sender_check.h"

namespace evermap::messages {
namespace {

using Bytes = std::vector<uint8_t>;
using Kind = SenderCheck::Kind;
constexpr int64_t kWall = 1'800'000'000'000'000;  // µs

MacKey keyOf(uint8_t fill) {
  std::array<uint8_t, MacKey::kBytes> b;
  b.fill(fill);
  return MacKey::fromBytes(b);
}

Bytes imuBytes(int64_t utime) {
  imu_t m{};
  m.utime = utime;
  Bytes b(static_cast<size_t>(m.getEncodedSize()));
  m.encode(b.data(), 0, static_cast<int>(b.size()));
  return b;
}

Bytes sealed(const Bytes& message, const SenderId& who, uint64_t counter, int64_t wall,
             const MacKey* key, const std::string& channel = "IMU") {
  Bytes b = message;
  appendEnvelope(channel, Envelope{who, counter, wall, key != nullptr}, key, b);
  return b;
}

SenderCheck::Now at(double s, int64_t wall = kWall) {
  return SenderCheck::Now{std::chrono::steady_clock::time_point{} +
                              std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                  std::chrono::duration<double>(1000.0 + s)),
                          wall};
}

SenderCheck::Result check(SenderCheck& c, const Bytes& b, SenderCheck::Now now,
                          const std::string& channel = "IMU") {
  return c.check(channel, b.data(), static_cast<int64_t>(b.size()), now);
}

const SenderId kVo{"evermap-vo-proc", 0x1234};
const SenderId kOther{"evermap-vo-proc", 0x9999};

TEST(Envelope, RoundTripsTheSenderAndLeavesTheMessageBytes) {
  const MacKey key = keyOf(7);
  const Bytes message = imuBytes(42);
  const Bytes b = sealed(message, kVo, 5, kWall, &key);
  auto opened = openEnvelope("IMU", b.data(), static_cast<int64_t>(b.size()), &key);
  ASSERT_TRUE(opened);
  EXPECT_EQ(opened->message_size, static_cast<int64_t>(message.size()));
  ASSERT_TRUE(opened->envelope);
  EXPECT_EQ(opened->envelope->sender, kVo);
  EXPECT_EQ(opened->envelope->counter, 5u);
  EXPECT_EQ(opened->envelope->wall_utime, kWall);
  EXPECT_TRUE(opened->mac_valid);
  EXPECT_EQ(messageSize(b.data(), static_cast<int64_t>(b.size())),
            static_cast<int64_t>(message.size()));
  EXPECT_EQ(kVo.toString(), "evermap-vo-proc#0000000000001234");
}

TEST(Envelope, AMessageWithoutOneIsAnonymous) {
  const Bytes message = imuBytes(42);
  auto opened = openEnvelope("IMU", message.data(), static_cast<int64_t>(message.size()), nullptr);
  ASSERT_TRUE(opened);
  EXPECT_FALSE(opened->envelope);
  EXPECT_EQ(opened->message_size, static_cast<int64_t>(message.size()));
}

TEST(Envelope, ATrailerLongerThanTheMessageIsAnError) {
  Bytes b = sealed(Bytes{}, kVo, 1, kWall, nullptr);  // 15 + 24 + 10 bytes
  b[b.size() - 10] = 64;                              // the name's length
  EXPECT_FALSE(openEnvelope("IMU", b.data(), static_cast<int64_t>(b.size()), nullptr));
  b[b.size() - 10] = 65;
  EXPECT_FALSE(openEnvelope("IMU", b.data(), static_cast<int64_t>(b.size()), nullptr));
}

TEST(Envelope, EveryTamperedByteFailsTheMac) {
  const MacKey key = keyOf(7);
  const Bytes b = sealed(imuBytes(42), kVo, 5, kWall, &key);
  for (size_t k = 0; k < b.size(); ++k) {
    Bytes t = b;
    t[k] ^= 0x01;
    auto opened = openEnvelope("IMU", t.data(), static_cast<int64_t>(t.size()), &key);
    EXPECT_TRUE(!opened || !opened->mac_valid) << "byte " << k;
  }
  // The same bytes on another channel: the channel is under the mac too.
  auto moved = openEnvelope("ATTITUDE", b.data(), static_cast<int64_t>(b.size()), &key);
  ASSERT_TRUE(moved);
  EXPECT_FALSE(moved->mac_valid);
}

TEST(SenderCheck, AWrongKeyOrNoMacIsRefused) {
  const MacKey key = keyOf(7), wrong = keyOf(8);
  SenderCheck c(&key, {});
  EXPECT_EQ(check(c, sealed(imuBytes(1), kVo, 1, kWall, &wrong), at(0)).kind,
            Kind::kUnauthenticated);
  EXPECT_EQ(check(c, sealed(imuBytes(1), kVo, 2, kWall, nullptr), at(0)).kind,
            Kind::kUnauthenticated);
  EXPECT_EQ(check(c, imuBytes(1), at(0)).kind, Kind::kUnauthenticated);
  const SenderCheck::Result r = check(c, sealed(imuBytes(1), kVo, 3, kWall, &key), at(0));
  EXPECT_EQ(r.kind, Kind::kAccept);
  EXPECT_EQ(r.message_size, static_cast<int64_t>(imuBytes(1).size()));
}

TEST(SenderCheck, AReplayedCounterOrAnOldMessageIsRefused) {
  const MacKey key = keyOf(7);
  SenderCheck c(&key, {});
  const Bytes first = sealed(imuBytes(1), kVo, 10, kWall, &key);
  EXPECT_EQ(check(c, first, at(0)).kind, Kind::kAccept);
  EXPECT_EQ(check(c, first, at(0.1)).kind, Kind::kReplayed);
  EXPECT_EQ(check(c, sealed(imuBytes(2), kVo, 9, kWall, &key), at(0.1)).kind, Kind::kReplayed);
  EXPECT_EQ(check(c, sealed(imuBytes(2), kVo, 11, kWall, &key), at(0.1)).kind, Kind::kAccept);
  // The counter is per channel: counter 11 is new on ATTITUDE.
  EXPECT_EQ(
      check(c, sealed(imuBytes(2), kVo, 11, kWall, &key, "ATTITUDE"), at(0.1), "ATTITUDE").kind,
      Kind::kAccept);
  // A receiver that forgot the counters still refuses what was sent beyond the window (30 s).
  SenderCheck restarted(&key, {});
  EXPECT_EQ(check(restarted, first, at(0, kWall + 31'000'000)).kind, Kind::kReplayed);
  EXPECT_EQ(check(restarted, first, at(0, kWall + 29'000'000)).kind, Kind::kAccept);
}

TEST(SenderCheck, ASecondSenderOnAChannelIsIgnored) {
  SenderCheck c(nullptr, {});
  EXPECT_EQ(check(c, sealed(imuBytes(1), kVo, 1, kWall, nullptr), at(0)).kind, Kind::kAccept);
  const SenderCheck::Result other = check(c, sealed(imuBytes(1), kOther, 1, kWall, nullptr), at(1));
  EXPECT_EQ(other.kind, Kind::kOtherSender);
  EXPECT_NE(other.note.find("ignoring evermap-vo-proc#0000000000009999"), std::string::npos);
  // One line per new sender, not per message.
  EXPECT_TRUE(check(c, sealed(imuBytes(1), kOther, 2, kWall, nullptr), at(1.5)).note.empty());
  EXPECT_EQ(check(c, imuBytes(1), at(1.6)).kind, Kind::kOtherSender);  // anonymous
  EXPECT_EQ(c.lockedSender("IMU"), kVo);
  // Another channel has a lock of its own.
  EXPECT_EQ(check(c, sealed(imuBytes(1), kOther, 3, kWall, nullptr), at(1.7), "ATTITUDE").kind,
            Kind::kAccept);
}

TEST(SenderCheck, TheLockPassesOnAfterTheSenderFellSilent) {
  SenderCheck c(nullptr, {});  // silence_s 2
  EXPECT_EQ(check(c, sealed(imuBytes(1), kVo, 1, kWall, nullptr), at(0)).kind, Kind::kAccept);
  EXPECT_EQ(check(c, sealed(imuBytes(1), kOther, 1, kWall, nullptr), at(1.9)).kind,
            Kind::kOtherSender);
  // kVo heard on another channel at 1.0 s: still alive at 2.5 s.
  check(c, sealed(imuBytes(1), kVo, 2, kWall, nullptr), at(1.0), "ATTITUDE");
  EXPECT_EQ(check(c, sealed(imuBytes(1), kOther, 2, kWall, nullptr), at(2.5)).kind,
            Kind::kOtherSender);
  const SenderCheck::Result taken =
      check(c, sealed(imuBytes(1), kOther, 3, kWall, nullptr), at(3.1));
  EXPECT_EQ(taken.kind, Kind::kAccept);
  EXPECT_NE(taken.note.find("sender now evermap-vo-proc#0000000000009999"), std::string::npos);
  EXPECT_EQ(c.lockedSender("IMU"), kOther);
  EXPECT_EQ(check(c, sealed(imuBytes(1), kVo, 3, kWall, nullptr), at(3.2)).kind,
            Kind::kOtherSender);
}

TEST(SenderCheck, ASharedChannelTakesEverySender) {
  SenderCheck c(nullptr, {});
  c.shareChannel("INPUT_STATS");
  EXPECT_EQ(check(c, sealed(imuBytes(1), kVo, 1, kWall, nullptr), at(0), "INPUT_STATS").kind,
            Kind::kAccept);
  EXPECT_EQ(check(c, sealed(imuBytes(1), kOther, 1, kWall, nullptr), at(0), "INPUT_STATS").kind,
            Kind::kAccept);
}

class KeyFile : public ::testing::Test {
 protected:
  std::filesystem::path write(const std::string& text, mode_t mode) {
    std::ofstream(file_) << text;
    ::chmod(file_.c_str(), mode);
    return file_;
  }
  void TearDown() override { std::filesystem::remove(file_); }
  std::filesystem::path file_ =
      std::filesystem::temp_directory_path() / ("evermap-key-test-" + std::to_string(::getpid()));
  const std::string hex_ = std::string(64, 'a') + "\n";
};

TEST_F(KeyFile, IsReadWhenOnlyItsOwnerMayReadIt) {
  auto key = MacKey::load(write(hex_, 0600));
  ASSERT_TRUE(key) << key.error().message;
  EXPECT_EQ(key->data()[0], 0xaa);
  EXPECT_TRUE(MacKey::load(write(hex_, 0400)));
}

TEST_F(KeyFile, IsRefusedWhenOthersMayReadItOrItIsNotAKey) {
  auto open = MacKey::load(write(hex_, 0644));
  ASSERT_FALSE(open);
  EXPECT_NE(open.error().message.find("mode 644"), std::string::npos) << open.error().message;
  EXPECT_FALSE(MacKey::load(write(hex_, 0640)));
  EXPECT_FALSE(MacKey::load(write("aabb\n", 0600)));
  EXPECT_FALSE(MacKey::load(write(std::string(64, 'g'), 0600)));
  EXPECT_FALSE(MacKey::load(file_.string() + ".missing"));
}

// Over memq://: a process with a key takes what a sender with the key publishes and refuses
// what one without it does (counted as unauthenticated); INPUT_STATS goes out sealed.
TEST(InboxWithKey, RefusesWhatAKeylessSenderPublishes) {
  lcm::LCM lcm("memq://");
  auto key = std::make_shared<const MacKey>(keyOf(3));
  Inbox::Options o;
  o.process = "envelope-test";
  o.signer = Signer::make("envelope-test", key);
  Inbox inbox(lcm, o);
  std::vector<int64_t> seen;
  inbox.subscribe<imu_t>(channels::kImu, [&](const imu_t& m) { seen.push_back(m.utime); });
  const Outbox keyed(lcm, Signer::make("sender", key));
  const Outbox keyless(lcm, Signer::make("stranger", nullptr));
  const Outbox wrong(lcm, Signer::make("stranger", std::make_shared<const MacKey>(keyOf(4))));
  const auto drain = [&] {
    while (lcm.handleTimeout(0) > 0) {
    }
  };
  imu_t m{};
  m.linear_acceleration[2] = 9.81;
  for (int64_t k = 0; k < 5; ++k) {
    m.utime = 1'400'000'000'000'000 + k * 1000;
    keyed.publish(channels::kImu, m);
    drain();
    keyless.publish(channels::kImu, m);
    drain();
    wrong.publish(channels::kImu, m);
    drain();
    lcm.publish(channels::kImu, &m);  // anonymous
    drain();
  }
  EXPECT_EQ(seen.size(), 5u);
  const ChannelCounts& c = inbox.counts().at(channels::kImu);
  EXPECT_EQ(c.received, 20);
  EXPECT_EQ(c.unauthenticated, 15);
  EXPECT_EQ(inbox.senderOf(channels::kImu).rfind("sender#", 0), 0u);
}

}  // namespace
}  // namespace evermap::messages
