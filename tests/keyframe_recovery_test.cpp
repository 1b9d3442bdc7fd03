// Keyframe recovery over a lossy link, its two halves without LCM: vo-proc's bounded buffer of
// recent keyframes and its rate-limited resender (vo-proc/keyframe_buffer.h), and
// loopclose-proc's schedule of asks with backoff (loopclose-proc/keyframe_requests.h). The
// two wired over memq:// are in loopclose_test.cpp.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "loopclose-proc/keyframe_requests.h"
#include "tests/register_results.h"
#include "vo-proc/keyframe_buffer.h"

namespace evermap {
namespace {

using testing::emptyKeyframe;
using testing::kSecond;

keyframe_request_t ask(int64_t keyframe_utime) {
  keyframe_request_t r{};
  r.utime = keyframe_utime;
  r.keyframe_utime = keyframe_utime;
  r.attempt = 1;
  return r;
}

TEST(KeyframeBuffer, KeepsTheNewestByCountAndBySecondsAndFindsThemByUtime) {
  vo::KeyframeBuffer by_count(3, 100.0);
  for (int k = 1; k <= 5; ++k) by_count.keep(emptyKeyframe(k * kSecond));
  EXPECT_EQ(by_count.size(), 3u);
  EXPECT_EQ(by_count.find(2 * kSecond), nullptr);
  ASSERT_NE(by_count.find(3 * kSecond), nullptr);
  EXPECT_EQ(by_count.find(3 * kSecond)->utime, 3 * kSecond);
  EXPECT_EQ(by_count.find(3 * kSecond + 1), nullptr);

  vo::KeyframeBuffer by_age(100, 2.5);
  for (int k = 1; k <= 5; ++k) by_age.keep(emptyKeyframe(k * kSecond));
  EXPECT_EQ(by_age.size(), 3u);  // 3, 4 and 5 s: within 2.5 s of the newest
  EXPECT_EQ(by_age.find(2 * kSecond), nullptr);
  EXPECT_NE(by_age.find(3 * kSecond), nullptr);
}

TEST(KeyframeBuffer, AKeyframeNotAfterTheNewestStartsItAgain) {
  vo::KeyframeBuffer buffer(10, 100.0);
  for (int k = 1; k <= 3; ++k) buffer.keep(emptyKeyframe(100 * kSecond + k));
  buffer.keep(emptyKeyframe(5 * kSecond));  // the log replayed again
  EXPECT_EQ(buffer.size(), 1u);
  EXPECT_NE(buffer.find(5 * kSecond), nullptr);
  vo::KeyframeBuffer none(0, 100.0);
  none.keep(emptyKeyframe(kSecond));
  EXPECT_EQ(none.size(), 0u);
}

TEST(KeyframeResender, AnswersAKeptKeyframeAndCountsWhatItDoesNotKnow) {
  vo::KeyframeResender resender(vo::KeyframeResendOptions{});
  resender.keep(emptyKeyframe(10 * kSecond));
  const auto k = resender.answer(ask(10 * kSecond), 0.0);
  ASSERT_TRUE(k.has_value());
  EXPECT_EQ(k->utime, 10 * kSecond);
  // Hostile or mistaken asks: nothing published, counted, nothing breaks.
  for (int64_t u : {int64_t{-1}, int64_t{0}, 10 * kSecond + 1, std::numeric_limits<int64_t>::max(),
                    std::numeric_limits<int64_t>::min()}) {
    EXPECT_FALSE(resender.answer(ask(u), 1.0).has_value()) << u;
  }
  EXPECT_EQ(resender.stats().requests, 6);
  EXPECT_EQ(resender.stats().resent, 1);
  EXPECT_EQ(resender.stats().unknown, 5);
}

TEST(KeyframeResender, AFloodOfAsksGetsAtMostTheRateAndOneKeyframeOncePerInterval) {
  vo::KeyframeResendOptions o;
  o.max_rate_hz = 5.0;
  o.min_interval_s = 0.5;
  vo::KeyframeResender resender(o);
  for (int k = 1; k <= 20; ++k) resender.keep(emptyKeyframe(k * kSecond));
  // The same keyframe 100 times in 0.1 s: once.
  int sent = 0;
  for (int i = 0; i < 100; ++i) sent += resender.answer(ask(kSecond), 0.001 * i).has_value();
  EXPECT_EQ(sent, 1);
  EXPECT_EQ(resender.stats().too_soon, 99);
  // Twenty keyframes at once: the burst (one second's worth, 5), then none at the same time.
  sent = 0;
  for (int k = 1; k <= 20; ++k) sent += resender.answer(ask(k * kSecond), 0.2).has_value();
  EXPECT_EQ(sent, 4);  // 5 tokens, one spent on the first
  EXPECT_GT(resender.stats().over_rate, 0);
  // One second later: 5 more at most, whatever is asked.
  sent = 0;
  for (int k = 1; k <= 20; ++k) sent += resender.answer(ask(k * kSecond), 1.2).has_value();
  EXPECT_EQ(sent, 5);
  // A clock that goes back, or is not finite, lets nothing more through.
  sent = 0;
  for (double t : {0.0, -1e9, std::nan(""), 1.2}) {
    for (int k = 1; k <= 20; ++k) sent += resender.answer(ask(k * kSecond), t).has_value();
  }
  EXPECT_EQ(sent, 0);
  EXPECT_EQ(resender.stats().resent, 10);
}

TEST(KeyframeResendOptions, OutOfRangeValuesAreRefusedNamingTheOption) {
  vo::KeyframeResendOptions o;
  EXPECT_TRUE(o.validate().ok());
  o.max_rate_hz = 0.0;
  const Status s = o.validate();
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("max_rate_hz"), std::string::npos) << s.error().message;
  o = vo::KeyframeResendOptions{};
  o.keyframes = -1;
  EXPECT_FALSE(o.validate().ok());
}

loopclose::KeyframeRequestOptions fastAsks() {
  loopclose::KeyframeRequestOptions o;
  o.max_attempts = 4;
  o.first_ask_after_us = 100'000;
  o.retry_us = 200'000;
  o.backoff = 2.0;
  o.max_retry_us = 500'000;
  return o;
}

TEST(KeyframeRequests, AsksAfterTheGraceThenBacksOffThenGivesUp) {
  loopclose::KeyframeRequests r(fastAsks());
  std::vector<int64_t> given_up;
  const int64_t t = 100 * kSecond, kf = t;
  ASSERT_TRUE(r.need(kf, t));
  EXPECT_TRUE(r.awaits(kf));
  EXPECT_TRUE(r.due(t + 99'999, &given_up).empty());  // it may still come on its own
  // Asks at +0.1 s, then after 0.2, 0.4, 0.5 (capped) s; given up 0.5 s after the fourth.
  std::vector<int64_t> asked_at;
  for (int64_t now = t; now <= t + 3 * kSecond; now += 10'000) {
    for (const keyframe_request_t& a : r.due(now, &given_up)) {
      EXPECT_EQ(a.keyframe_utime, kf);
      EXPECT_EQ(a.attempt, static_cast<int32_t>(asked_at.size()) + 1);
      asked_at.push_back(now - t);
    }
  }
  EXPECT_EQ(asked_at, (std::vector<int64_t>{100'000, 300'000, 700'000, 1'200'000}));
  ASSERT_EQ(given_up, std::vector<int64_t>{kf});
  EXPECT_FALSE(r.awaits(kf));
  EXPECT_EQ(r.stats().asked, 1);
  EXPECT_EQ(r.stats().asks, 4);
  EXPECT_EQ(r.stats().given_up, 1);
  EXPECT_EQ(r.stats().recovered, 0);
}

TEST(KeyframeRequests, AKeyframeThatComesIsRecoveredOnlyIfItWasAskedFor) {
  loopclose::KeyframeRequests r(fastAsks());
  std::vector<int64_t> given_up;
  const int64_t t = 100 * kSecond;
  ASSERT_TRUE(r.need(t, t));
  ASSERT_TRUE(r.need(t, t + 50'000));  // needed again: still one
  EXPECT_EQ(r.open(), 1u);
  r.received(t);  // in flight, not lost: no ask
  EXPECT_EQ(r.stats().asked, 0);
  EXPECT_EQ(r.stats().recovered, 0);
  ASSERT_TRUE(r.need(t + kSecond, t + kSecond));
  EXPECT_EQ(r.due(t + 2 * kSecond, &given_up).size(), 1u);
  r.received(t + kSecond);
  EXPECT_EQ(r.stats().recovered, 1);
  EXPECT_EQ(r.open(), 0u);
  EXPECT_TRUE(given_up.empty());
}

TEST(KeyframeRequests, APartitionSpendsOneAttemptNotAll) {
  loopclose::KeyframeRequests r(fastAsks());
  std::vector<int64_t> given_up;
  const int64_t t = 100 * kSecond;
  ASSERT_TRUE(r.need(t, t));
  EXPECT_EQ(r.due(t + 100'000, &given_up).size(), 1u);
  // 15 s without data, then the data again: one ask, the next after the backed-off wait.
  EXPECT_EQ(r.due(t + 15 * kSecond, &given_up).size(), 1u);
  EXPECT_TRUE(r.due(t + 15 * kSecond + 100'000, &given_up).empty());
  EXPECT_EQ(r.due(t + 15 * kSecond + 400'000, &given_up).size(), 1u);
  EXPECT_TRUE(given_up.empty());
}

TEST(KeyframeRequests, AtMostMaxOpenAreAwaitedAndNoneWhenDisabled) {
  loopclose::KeyframeRequestOptions o = fastAsks();
  o.max_open = 2;
  loopclose::KeyframeRequests r(o);
  EXPECT_TRUE(r.need(1, 0));
  EXPECT_TRUE(r.need(2, 0));
  EXPECT_FALSE(r.need(3, 0));
  EXPECT_EQ(r.stats().refused, 1);
  o.max_attempts = 0;
  loopclose::KeyframeRequests off(o);
  EXPECT_FALSE(off.enabled());
  EXPECT_FALSE(off.need(1, 0));
  loopclose::KeyframeRequestOptions bad = fastAsks();
  bad.max_retry_us = 100'000;  // below retry_us
  EXPECT_FALSE(bad.validate().ok());
  bad = fastAsks();
  bad.backoff = 0.5;
  EXPECT_FALSE(bad.validate().ok());
}

}  // namespace
}  // namespace evermap
