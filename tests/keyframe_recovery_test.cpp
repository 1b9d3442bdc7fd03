// Keyframe recovery over a lossy link, its parts without LCM: a keyframe in parts of one
// packet (core/messages/keyframe_parts.h), vo-proc's bounded buffer of recent keyframes and
// its rate-limited resender (vo-proc/keyframe_buffer.h), and loopclose-proc's schedule of asks
// with backoff (loopclose-proc/keyframe_requests.h). The two wired over memq:// are in
// loopclose_recovery_test.cpp.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include "core/messages/keyframe_parts.h"
#include "loopclose-proc/keyframe_requests.h"
#include "tests/register_results.h"
#include "vo-proc/keyframe_buffer.h"

namespace evermap {
namespace {

using testing::emptyKeyframe;
using testing::kSecond;

keyframe_request_t ask(int64_t keyframe_utime, std::vector<int16_t> missing = {}) {
  keyframe_request_t r{};
  r.utime = keyframe_utime;
  r.keyframe_utime = keyframe_utime;
  r.attempt = 1;
  r.missing = std::move(missing);
  r.num_missing = static_cast<int16_t>(r.missing.size());
  return r;
}

// A keyframe of `n` features with random content (a typical one has 650: 37 KB).
keyframe_t featureKeyframe(int64_t utime, int n) {
  keyframe_t k = emptyKeyframe(utime);
  std::mt19937 rng(static_cast<uint32_t>(utime));
  std::uniform_real_distribution<float> u(0.0f, 400.0f);
  k.num_features = n;
  for (int i = 0; i < n; ++i) {
    k.keypoints.push_back({u(rng), u(rng)});
    k.points.push_back({u(rng), u(rng), u(rng)});
    k.disparity.push_back(u(rng));
    k.level.push_back(static_cast<int8_t>(i % 4));
    std::vector<uint8_t> d(32);
    for (uint8_t& b : d) b = static_cast<uint8_t>(rng());
    k.descriptors.push_back(d);
  }
  return k;
}

std::vector<uint8_t> encoded(const keyframe_t& k) {
  std::vector<uint8_t> b(static_cast<size_t>(k.getEncodedSize()));
  k.encode(b.data(), 0, static_cast<int>(b.size()));
  return b;
}

TEST(KeyframeParts, ATypicalKeyframeIsThirtyOnePartsOfOnePacketThatJoinInAnyOrder) {
  const keyframe_t k = featureKeyframe(7 * kSecond, 650);
  const std::vector<keyframe_part_t> parts = messages::splitKeyframe(k);
  ASSERT_EQ(parts.size(), 31u);
  for (const keyframe_part_t& p : parts) {
    // One IP packet at MTU 1500: the part, LCM's header (22 bytes for this channel), the
    // largest envelope (about 130), UDP and IP (28).
    EXPECT_LE(p.getEncodedSize() + 22 + 130 + 28, 1500) << p.index;
    EXPECT_EQ(p.count, 31);
    EXPECT_EQ(p.utime, k.utime);
  }
  messages::KeyframeAssembler assembler;
  std::vector<keyframe_part_t> shuffled = parts;
  std::shuffle(shuffled.begin(), shuffled.end(), std::mt19937(3));
  EXPECT_TRUE(assembler.missing(k.utime).empty());  // nothing held: the whole keyframe
  for (size_t i = 0; i + 1 < shuffled.size(); ++i) {
    auto r = assembler.add(shuffled[i]);
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_FALSE(r->has_value());
    EXPECT_FALSE(assembler.add(shuffled[i])->has_value());  // a repeat changes nothing
  }
  EXPECT_EQ(assembler.missing(k.utime), std::vector<int16_t>{shuffled.back().index});
  auto whole = assembler.add(shuffled.back());
  ASSERT_TRUE(whole.ok()) << whole.error().message;
  ASSERT_TRUE(whole->has_value());
  EXPECT_EQ(encoded(**whole), encoded(k));
  EXPECT_FALSE(assembler.holds(k.utime));
  EXPECT_EQ(assembler.bytesHeld(), 0);
}

TEST(KeyframeParts, MalformedOrHostilePartsAreRefusedNamingTheKeyframe) {
  const keyframe_t k = featureKeyframe(9 * kSecond, 100);
  const std::vector<keyframe_part_t> parts = messages::splitKeyframe(k);
  ASSERT_EQ(parts.size(), 5u);
  messages::KeyframeAssembler assembler;
  const auto refused = [&](keyframe_part_t p, const char* what) {
    auto r = assembler.add(p);
    ASSERT_FALSE(r.ok()) << what;
    EXPECT_NE(r.error().message.find(std::to_string(p.utime)), std::string::npos)
        << r.error().message;
  };
  keyframe_part_t p = parts[1];
  p.total_bytes = messages::kMaxKeyframeBytes + 1;
  refused(p, "total_bytes too large");
  p = parts[1];
  p.index = 5;
  refused(p, "index beyond count");
  p = parts[1];
  p.size = 10;
  refused(p, "size not that of data");
  p = parts[1];
  p.offset = p.total_bytes - 10;
  refused(p, "data outside the keyframe");
  // Parts that do not tile the keyframe: an offset out of step.
  for (size_t i = 0; i < parts.size(); ++i) {
    p = parts[i];
    if (i == 2) p.offset -= 1;
    auto r = assembler.add(p);
    if (i + 1 < parts.size()) {
      ASSERT_TRUE(r.ok()) << r.error().message;
    } else {
      EXPECT_FALSE(r.ok());
    }
  }
  EXPECT_EQ(assembler.bytesHeld(), 0);
  // Bytes that tile but claim two billion features: refused before the decoder allocates.
  keyframe_t liar = featureKeyframe(9 * kSecond, 0);
  std::vector<uint8_t> bytes = encoded(liar);
  const size_t num_features_at = bytes.size() - 4;  // the last field of an empty keyframe
  bytes[num_features_at] = 0x7f;
  keyframe_part_t whole{};
  whole.utime = liar.utime;
  whole.total_bytes = static_cast<int32_t>(bytes.size());
  whole.count = 1;
  whole.size = whole.total_bytes;
  whole.data = bytes;
  EXPECT_FALSE(assembler.add(whole).ok());
  // The parts of another keyframe under this one's utime.
  std::vector<keyframe_part_t> other = messages::splitKeyframe(featureKeyframe(8 * kSecond, 10));
  ASSERT_EQ(other.size(), 1u);
  other[0].utime = 9 * kSecond;
  EXPECT_FALSE(assembler.add(other[0]).ok());
  // At most max_bytes held.
  messages::KeyframeAssembler small(2000);
  ASSERT_TRUE(small.add(parts[0]).ok());
  EXPECT_FALSE(small.add(parts[1]).ok());
}

TEST(KeyframeParts, APartOfAnotherLayoutStartsTheKeyframeAgain) {
  const keyframe_t k = featureKeyframe(9 * kSecond, 100);
  messages::KeyframeAssembler assembler;
  const std::vector<keyframe_part_t> small = messages::splitKeyframe(k, 500);
  ASSERT_TRUE(assembler.add(small[0]).ok());
  const std::vector<keyframe_part_t> parts = messages::splitKeyframe(k);
  for (size_t i = 0; i < parts.size(); ++i) {
    auto r = assembler.add(parts[i]);
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_EQ(r->has_value(), i + 1 == parts.size());
  }
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
  ASSERT_EQ(k.size(), 1u);  // an empty keyframe is one part
  EXPECT_EQ(k[0].utime, 10 * kSecond);
  // Hostile or mistaken asks: nothing published, counted, nothing breaks.
  for (int64_t u : {int64_t{-1}, int64_t{0}, 10 * kSecond + 1, std::numeric_limits<int64_t>::max(),
                    std::numeric_limits<int64_t>::min()}) {
    EXPECT_TRUE(resender.answer(ask(u), 1.0).empty()) << u;
  }
  // Parts it does not have.
  EXPECT_TRUE(resender.answer(ask(10 * kSecond, {-1, 1, 32767}), 2.0).empty());
  EXPECT_EQ(resender.stats().requests, 7);
  EXPECT_EQ(resender.stats().resent, 1);
  EXPECT_EQ(resender.stats().unknown, 6);
}

TEST(KeyframeResender, AFloodOfAsksGetsAtMostTheRateAndOneKeyframeOncePerInterval) {
  vo::KeyframeResendOptions o;
  o.max_rate_hz = 5.0;
  o.min_interval_s = 0.5;
  vo::KeyframeResender resender(o);
  for (int k = 1; k <= 20; ++k) resender.keep(emptyKeyframe(k * kSecond));
  // The same keyframe 100 times in 0.1 s: once.
  int sent = 0;
  for (int i = 0; i < 100; ++i) sent += resender.answer(ask(kSecond), 0.001 * i).empty() ? 0 : 1;
  EXPECT_EQ(sent, 1);
  EXPECT_EQ(resender.stats().too_soon, 99);
  // Twenty keyframes at once: the burst (one second's worth, 5), then none at the same time.
  sent = 0;
  for (int k = 1; k <= 20; ++k) sent += resender.answer(ask(k * kSecond), 0.2).empty() ? 0 : 1;
  EXPECT_EQ(sent, 4);  // 5 tokens, one spent on the first
  EXPECT_GT(resender.stats().over_rate, 0);
  // One second later: 5 more at most, whatever is asked.
  sent = 0;
  for (int k = 1; k <= 20; ++k) sent += resender.answer(ask(k * kSecond), 1.2).empty() ? 0 : 1;
  EXPECT_EQ(sent, 5);
  // A clock that goes back, or is not finite, lets nothing more through.
  sent = 0;
  for (double t : {0.0, -1e9, std::nan(""), 1.2}) {
    for (int k = 1; k <= 20; ++k) sent += resender.answer(ask(k * kSecond), t).empty() ? 0 : 1;
  }
  EXPECT_EQ(sent, 0);
  EXPECT_EQ(resender.stats().resent, 10);
}

TEST(KeyframeResender, AnswersOnlyTheMissingPartsAndChargesTheirShareOfTheRate) {
  vo::KeyframeResendOptions o;
  o.max_rate_hz = 1.0;  // one keyframe's worth a second, a burst of one
  o.min_interval_s = 0.0;
  vo::KeyframeResender resender(o);
  resender.keep(featureKeyframe(kSecond, 650));
  const std::vector<keyframe_part_t> two = resender.answer(ask(kSecond, {30, 4, 999}), 0.0);
  ASSERT_EQ(two.size(), 2u);
  EXPECT_EQ(two[0].index, 4);
  EXPECT_EQ(two[1].index, 30);
  // 2 of 31 spent: the whole keyframe is over the rate now, 28 parts are not.
  EXPECT_TRUE(resender.answer(ask(kSecond), 0.0).empty());
  EXPECT_EQ(resender.stats().over_rate, 1);
  std::vector<int16_t> most(28);
  for (int16_t i = 0; i < 28; ++i) most[static_cast<size_t>(i)] = i;
  EXPECT_EQ(resender.answer(ask(kSecond, most), 0.0).size(), 28u);
  EXPECT_EQ(resender.stats().parts, 30);
  EXPECT_EQ(resender.stats().resent, 2);
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

TEST(KeyframeRequests, AsksNameTheMissingPartsAndTheJoinedKeyframeIsRecovered) {
  loopclose::KeyframeRequests r(fastAsks());
  std::vector<int64_t> given_up;
  const int64_t t = 100 * kSecond;
  const keyframe_t k = featureKeyframe(t, 100);
  const std::vector<keyframe_part_t> parts = messages::splitKeyframe(k);
  ASSERT_EQ(parts.size(), 5u);
  // Parts of a keyframe not awaited are ignored.
  ASSERT_TRUE(r.addPart(parts[0]).ok());
  EXPECT_EQ(r.stats().parts_unasked, 1);
  ASSERT_TRUE(r.need(t, t));
  std::vector<keyframe_request_t> asks = r.due(t + 100'000, &given_up);
  ASSERT_EQ(asks.size(), 1u);
  EXPECT_EQ(asks[0].num_missing, 0);  // nothing held: all of it
  for (int i : {0, 2, 3}) {
    auto got = r.addPart(parts[static_cast<size_t>(i)]);
    ASSERT_TRUE(got.ok());
    EXPECT_FALSE(got->has_value());
  }
  asks = r.due(t + 300'000, &given_up);
  ASSERT_EQ(asks.size(), 1u);
  EXPECT_EQ(asks[0].missing, (std::vector<int16_t>{1, 4}));
  EXPECT_EQ(asks[0].num_missing, 2);
  ASSERT_TRUE(r.addPart(parts[1]).ok());
  auto whole = r.addPart(parts[4]);
  ASSERT_TRUE(whole.ok());
  ASSERT_TRUE(whole->has_value());
  EXPECT_EQ(encoded(**whole), encoded(k));
  r.received(t);
  EXPECT_EQ(r.stats().recovered, 1);
  EXPECT_EQ(r.stats().parts, 5);
  // A keyframe given up drops its parts: they are not joined later.
  ASSERT_TRUE(r.need(t + 1, t));
  ASSERT_TRUE(r.addPart(messages::splitKeyframe(featureKeyframe(t + 1, 100))[0]).ok());
  for (int64_t now = t; now <= t + 5 * kSecond; now += 100'000) r.due(now, &given_up);
  EXPECT_EQ(given_up, std::vector<int64_t>{t + 1});
  EXPECT_EQ(r.stats().parts_unasked, 1);
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
