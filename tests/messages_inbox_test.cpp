// core/messages/inbox.h over memq://: the input boundary every process uses. Malformed bytes
// are counted and never reach a handler, a throwing handler is caught and counted, a message
// stamped far from the stream's clock is held and refused (never "now"), a stream that really
// jumps is followed with nothing lost, and the counts go out as INPUT_STATS.
#include <gtest/gtest.h>

#include <cstdint>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include <evermap/imu_t.hpp>
#include <evermap/input_stats_t.hpp>
#include <evermap/stereo_calib_t.hpp>

#include "core/messages/channels.h"
#include "core/messages/inbox.h"

namespace evermap::messages {
namespace {

constexpr int64_t kT0 = 1'400'000'000'000'000;  // a 2014 stamp, µs
constexpr int64_t kFar = int64_t{1} << 62;
constexpr int64_t kDay = int64_t{86400} * 1'000'000;

class InboxTest : public ::testing::Test {
 protected:
  void drain() {
    while (lcm_.handleTimeout(0) > 0) {
    }
  }
  void publishImu(int64_t utime) {
    evermap::imu_t m{};
    m.utime = utime;
    m.linear_acceleration[2] = 9.81;
    lcm_.publish(channels::kImu, &m);
    drain();  // one at a time: memq queues are bounded too
  }
  // A sample of the stream at its clock: published and expected to be passed on.
  void publishOnClock(std::vector<int64_t>* sent, int64_t utime) {
    sent->push_back(utime);
    publishImu(utime);
  }
  // n stamps from `start`, `step` µs apart, appended to `sent`.
  static void appendStamps(std::vector<int64_t>* sent, int64_t start, int n, int64_t step) {
    for (int k = 0; k < n; ++k) sent->push_back(start + k * step);
  }
  // Every IMU sample the inbox passes on goes to seen_.
  void recordImu(Inbox& inbox) {
    inbox.subscribe<evermap::imu_t>(channels::kImu,
                                    [this](const evermap::imu_t& m) { seen_.push_back(m.utime); });
  }
  Inbox::Options options() const {
    Inbox::Options o;
    o.process = "inbox-test";
    return o;
  }
  // options() whose held messages expire after `expire_count` passed on.
  Inbox::Options expiringAfter(int expire_count) const {
    Inbox::Options o = options();
    o.time.expire_count = expire_count;
    return o;
  }
  // An inbox whose IMU samples go to seen_.
  std::unique_ptr<Inbox> recording(const Inbox::Options& o) {
    auto inbox = std::make_unique<Inbox>(lcm_, o);
    recordImu(*inbox);
    return inbox;
  }
  // Publishes `sent`; every sample is passed on in order, none dropped, after `jumps` jumps.
  void expectAllPassedOn(const Inbox& inbox, const std::vector<int64_t>& sent, int jumps) {
    for (int64_t t : sent) publishImu(t);
    EXPECT_EQ(seen_, sent);
    EXPECT_EQ(inbox.total().dropped(), 0);
    EXPECT_EQ(inbox.clockJumps(), jumps);
  }

  lcm::LCM lcm_{"memq://"};
  std::vector<int64_t> seen_;
};

TEST_F(InboxTest, MalformedBytesAreCountedAndNeverReachTheHandler) {
  Inbox inbox(lcm_, options());
  inbox.subscribe<evermap::stereo_calib_t>(
      channels::kStereoCalib, [&](const evermap::stereo_calib_t& m) { seen_.push_back(m.utime); });
  evermap::stereo_calib_t c{};
  c.utime = kT0;
  std::vector<uint8_t> b(static_cast<size_t>(c.getEncodedSize()));
  c.encode(b.data(), 0, static_cast<int>(b.size()));
  // left.num_distortion := 2^28 (issue 17: vo-proc SIGSEGV).
  std::vector<uint8_t> bad = b;
  const size_t at = 8 + 8 + 1 + 8 + 32 + 1;
  bad[at] = 0x10;
  bad[at + 1] = bad[at + 2] = bad[at + 3] = 0;
  lcm_.publish(channels::kStereoCalib, bad.data(), static_cast<unsigned>(bad.size()));
  drain();
  const char junk[] = "junk";
  lcm_.publish(channels::kStereoCalib, junk, sizeof junk);
  drain();
  EXPECT_TRUE(seen_.empty());
  const ChannelCounts& k = inbox.counts().at(channels::kStereoCalib);
  EXPECT_EQ(k.received, 2);
  EXPECT_EQ(k.malformed, 2);
  EXPECT_EQ(inbox.total().dropped(), 2);
}

TEST_F(InboxTest, AnExceptionInAHandlerIsCaughtAndCounted) {
  Inbox::Options o = options();
  o.time.window_s = 0.0;
  Inbox inbox(lcm_, o);
  inbox.subscribe<evermap::imu_t>(channels::kImu, [&](const evermap::imu_t& m) {
    if (m.utime == 2) throw std::length_error("boom");
    seen_.push_back(m.utime);
  });
  for (int64_t t : {1, 2, 3}) publishImu(t);
  EXPECT_EQ(seen_, (std::vector<int64_t>{1, 3}));
  EXPECT_EQ(inbox.counts().at(channels::kImu).failed, 1);
}

TEST_F(InboxTest, AMessageStampedTwoToThe62IsRefusedAndNeverBecomesNow) {
  auto inbox = recording(expiringAfter(50));
  std::vector<int64_t> sent;
  for (int k = 0; k < 200; ++k) {
    if (k == 100) {
      publishImu(kFar);
      publishImu(kFar);  // a copy confirms nothing
    }
    publishOnClock(&sent, kT0 + k * 5000);
  }
  EXPECT_EQ(seen_, sent);  // every sample of the stream, in order, and nothing else
  EXPECT_EQ(inbox->counts().at(channels::kImu).time_refused, 2);
  EXPECT_EQ(inbox->held(), 0);
}

TEST_F(InboxTest, TheFirstMessagesWaitUntilTheyAgreeSoAFarFirstMessageIsNotTheClock) {
  auto inbox = recording(expiringAfter(10));
  publishImu(kFar);
  publishImu(kT0);
  publishImu(kT0 + 5000);
  EXPECT_TRUE(seen_.empty());  // two distinct stamps agree: not yet three
  publishImu(kT0 + 10000);
  EXPECT_EQ(seen_, (std::vector<int64_t>{kT0, kT0 + 5000, kT0 + 10000}));
  for (int k = 3; k < 20; ++k) publishImu(kT0 + k * 5000);
  EXPECT_EQ(seen_.size(), 20u);
  EXPECT_EQ(inbox->counts().at(channels::kImu).time_refused, 1);
}

TEST_F(InboxTest, AStreamThatReallyJumpsIsFollowedWithNothingLost) {
  // A new session a day later (or a log replayed again): after confirm_count messages agree,
  // the clock moves and the held messages are passed on in order.
  auto inbox = recording(options());
  // 40 samples at 200 Hz each: past confirm_span_s (0.1 s) within max_held.
  std::vector<int64_t> sent;
  appendStamps(&sent, kT0, 40, 5000);
  appendStamps(&sent, kT0 + kDay, 40, 5000);
  appendStamps(&sent, kT0 - kDay, 40, 5000);  // and back
  expectAllPassedOn(*inbox, sent, 2);
}

TEST_F(InboxTest, ThreeDistinctFarStampsDoNotMoveTheClockWhileTheStreamGoesOn) {
  // Issue 47: three well-formed messages stamped near 2^62, 0.5 s apart (they agree and span
  // confirm_span_s), slipped into a live stream. The stream going on at the clock contradicts
  // them: they are refused and every sample of the stream is passed on.
  auto inbox = recording(expiringAfter(50));
  std::vector<int64_t> sent;
  for (int k = 0; k < 300; ++k) {
    if (k == 100 || k == 120 || k == 140) publishImu(kFar + (k - 100) * 25'000);
    publishOnClock(&sent, kT0 + k * 5000);
  }
  EXPECT_EQ(seen_, sent);
  EXPECT_EQ(inbox->counts().at(channels::kImu).time_refused, 3);
  EXPECT_EQ(inbox->clockJumps(), 0);
  EXPECT_GT(inbox->jumpsContradicted(), 0);
  EXPECT_EQ(inbox->held(), 0);
}

TEST_F(InboxTest, FarStampsSentTogetherDoNotMoveTheClockWhenTheStreamPauses) {
  // Stamps corrupted or forged together (microseconds apart) do not span confirm_span_s: the
  // stream that comes back after a pause goes on at its clock.
  auto inbox = recording(expiringAfter(20));
  std::vector<int64_t> sent;
  appendStamps(&sent, kT0, 10, 5000);
  for (int64_t t : sent) publishImu(t);
  for (int k = 0; k < 5; ++k) publishImu(kFar + k);
  for (int k = 10; k < 50; ++k) publishOnClock(&sent, kT0 + k * 5000);
  EXPECT_EQ(seen_, sent);
  EXPECT_EQ(inbox->clockJumps(), 0);
  EXPECT_EQ(inbox->counts().at(channels::kImu).time_refused, 5);
}

TEST_F(InboxTest, ANewSessionIsAdoptedThoughALateMessageOfTheOldOneArrivesAmongIt) {
  // A log replayed again: a message of the old session still in a queue arrives among the new
  // session's first ones. It does not outnumber them: the new clock is adopted, nothing lost.
  auto inbox = recording(options());
  std::vector<int64_t> sent;
  appendStamps(&sent, kT0, 40, 5000);
  const int64_t earlier = kT0 - int64_t{3600} * 1'000'000;
  appendStamps(&sent, earlier, 40, 5000);
  sent.insert(sent.begin() + 45, kT0 + 40 * 5000);  // the straggler
  for (int64_t t : sent) publishImu(t);
  EXPECT_EQ(seen_.size(), sent.size());
  EXPECT_EQ(inbox->total().dropped(), 0);
  EXPECT_EQ(inbox->clockJumps(), 1);
}

TEST_F(InboxTest, AFastStreamThatJumpsIsAdoptedWhenItFillsHalfOfTheHeldMessages) {
  // IMU at 1 kHz: 0.1 s would be 100 messages, more than max_held (64); half of it adopts.
  auto inbox = recording(options());
  std::vector<int64_t> sent;
  appendStamps(&sent, kT0, 40, 1000);
  appendStamps(&sent, kT0 + kDay, 200, 1000);
  expectAllPassedOn(*inbox, sent, 1);
}

TEST_F(InboxTest, CountsGoOutAsInputStats) {
  Inbox::Options o = options();
  o.time.confirm_count = 1;
  Inbox inbox(lcm_, o);
  recordImu(inbox);
  publishImu(kT0);
  const char junk[] = "junk";
  lcm_.publish(channels::kImu, junk, sizeof junk);
  drain();
  const evermap::input_stats_t s = inbox.statsMessage(kT0);
  ASSERT_EQ(s.num_channels, 1);
  EXPECT_EQ(s.channels[0], channels::kImu);
  EXPECT_EQ(s.received[0], 2);
  EXPECT_EQ(s.malformed[0], 1);
  EXPECT_EQ(s.process, "inbox-test");
  std::vector<uint8_t> b(static_cast<size_t>(s.getEncodedSize()));
  EXPECT_EQ(s.encode(b.data(), 0, static_cast<int>(b.size())), static_cast<int>(b.size()));
}

TEST(InboxOptions, RefuseNonsense) {
  Inbox::Options o;
  o.queue_capacity = -1;
  EXPECT_FALSE(o.validate().ok());
  o = Inbox::Options{};
  o.time.window_s = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(o.validate().ok());
  o.time.window_s = -1.0;
  EXPECT_FALSE(o.validate().ok());
  o = Inbox::Options{};
  o.time.confirm_count = 0;
  EXPECT_FALSE(o.validate().ok());
  o = Inbox::Options{};
  o.time.confirm_span_s = -0.1;
  EXPECT_FALSE(o.validate().ok());
  EXPECT_TRUE(Inbox::Options{}.validate().ok());
}

}  // namespace
}  // namespace evermap::messages
