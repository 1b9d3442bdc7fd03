// core/messages: the type registry and the log comparator, in-process over memq://.
#include <gtest/gtest.h>

#include <evermap/imu_t.hpp>
#include <evermap/stereo_image_t.hpp>
#include <filesystem>
#include <lcm/lcm-cpp.hpp>

#include "core/messages/channels.h"
#include "core/messages/envelope.h"
#include "tools/lcmlog/log_compare.h"
#include "tools/lcmlog/type_registry.h"

namespace evermap::messages {
namespace {

std::vector<uint8_t> encode(const auto& msg) {
  std::vector<uint8_t> buf(msg.getEncodedSize());
  msg.encode(buf.data(), 0, static_cast<int>(buf.size()));
  return buf;
}

evermap::imu_t imu(int64_t utime) {
  evermap::imu_t m{};
  m.utime = utime;
  m.linear_acceleration[2] = 9.81;
  return m;
}

evermap::stereo_image_t stereo(int64_t utime) {
  evermap::stereo_image_t m{};
  m.utime = utime;
  for (evermap::image_t* im : {&m.left, &m.right}) {
    im->utime = utime;
    im->width = 300;
    im->height = 300;
    im->row_stride = 300;
    im->pixelformat = evermap::image_t::FORMAT_GRAY8;
    im->data.assign(300 * 300, static_cast<uint8_t>(utime));
    im->size = static_cast<int32_t>(im->data.size());
  }
  return m;
}

std::filesystem::path writeLog(int n) {
  const auto path = std::filesystem::temp_directory_path() /
                    ("evermap_log_compare_" + std::to_string(::getpid()) + ".lcmlog");
  lcm::LogFile log(path.string(), "w");
  for (int i = 0; i < n; ++i) {
    for (auto [channel, bytes] : {std::pair{channels::kImu, encode(imu(i))},
                                  std::pair{channels::kStereo, encode(stereo(i))}}) {
      lcm::LogEvent ev{};
      ev.timestamp = i;
      ev.channel = channel;
      ev.datalen = static_cast<int32_t>(bytes.size());
      ev.data = bytes.data();
      log.writeEvent(&ev);
    }
  }
  return path;
}

// writeLog(n) and the comparator made from it; the log is removed with it.
struct LoggedComparator {
  explicit LoggedComparator(int n) : path(writeLog(n)), cmp(LogComparator::fromLog(path)) {}
  ~LoggedComparator() { std::filesystem::remove(path); }
  std::filesystem::path path;
  Expected<LogComparator> cmp;
};

// `bytes` handed to the comparator as a message received on `channel`.
void receive(LogComparator& cmp, const std::string& channel, const std::vector<uint8_t>& bytes) {
  cmp.onMessage(channel, bytes.data(), bytes.size());
}

TEST(TypeRegistry, KnowsEveryTypeAndIdentifiesEncodedMessages) {
  EXPECT_GE(allTypes().size(), 20u);
  const auto bytes = encode(imu(5));
  const auto t = identify(bytes.data(), bytes.size());
  ASSERT_TRUE(t.has_value());
  EXPECT_EQ(t->name, "imu_t");
  EXPECT_TRUE(decodesCleanly(bytes.data(), bytes.size()));
}

TEST(TypeRegistry, RejectsTruncatedAndUnknownMessages) {
  auto bytes = encode(stereo(1));
  EXPECT_FALSE(decodesCleanly(bytes.data(), bytes.size() - 10));
  EXPECT_FALSE(decodesCleanly(bytes.data(), 4));
  bytes[0] ^= 0xff;  // fingerprint no longer matches any type
  EXPECT_FALSE(identify(bytes.data(), bytes.size()).has_value());
  EXPECT_FALSE(decodesCleanly(bytes.data(), bytes.size()));
}

TEST(LogComparator, ReplayOverMemqArrivesIntact) {
  LoggedComparator logged(10);
  auto& cmp = logged.cmp;
  ASSERT_TRUE(cmp.ok()) << cmp.error().message;
  EXPECT_EQ(cmp->expectedTotal(), 20);

  lcm::LCM lcm("memq://");
  ASSERT_TRUE(lcm.good());
  lcm.subscribeFunction(
      ".*",
      +[](const lcm::ReceiveBuffer* rb, const std::string& ch, LogComparator* c) {
        c->onMessage(ch, rb->data, rb->data_size);
      },
      &*cmp);
  lcm::LogFile log(logged.path.string(), "r");
  while (const lcm::LogEvent* ev = log.readNextEvent())
    lcm.publish(ev->channel, ev->data, ev->datalen);
  while (lcm.handleTimeout(0) > 0) {
  }
  const auto s = cmp->summary();
  EXPECT_TRUE(cmp->allReceived());
  EXPECT_TRUE(s.complete()) << s.table();
  EXPECT_EQ(s.channels.at(channels::kStereo).type, "stereo_image_t");
  EXPECT_EQ(s.channels.at(channels::kImu).intact, 10);
}

// A process that signs what it publishes (evermap-sim-measure --serve) sends each logged
// message with its envelope behind it: the message is intact, the envelope is not compared.
TEST(LogComparator, MessagesWithASendersEnvelopeArriveIntact) {
  LoggedComparator logged(2);
  auto& cmp = logged.cmp;
  ASSERT_TRUE(cmp.ok()) << cmp.error().message;
  const Signer signer = Signer::make("evermap-sim-measure", nullptr);
  for (int i = 0; i < 2; ++i) {
    for (auto [channel, bytes] : {std::pair{channels::kImu, encode(imu(i))},
                                  std::pair{channels::kStereo, encode(stereo(i))}}) {
      const size_t plain = bytes.size();
      signer.seal(channel, bytes);
      ASSERT_GT(bytes.size(), plain);
      receive(*cmp, channel, bytes);
    }
  }
  const auto s = cmp->summary();
  EXPECT_TRUE(s.complete()) << s.table();
  EXPECT_EQ(s.channels.at(channels::kImu).undecodable, 0);
}

TEST(LogComparator, CountsMissingAndCorruptMessages) {
  LoggedComparator logged(3);
  auto& cmp = logged.cmp;
  ASSERT_TRUE(cmp.ok());
  receive(*cmp, channels::kImu, encode(imu(0)));
  auto bad = encode(imu(1));
  bad.back() ^= 0x01;  // one flipped bit in the payload
  receive(*cmp, channels::kImu, bad);
  const auto s = cmp->summary();
  EXPECT_FALSE(s.complete());
  EXPECT_EQ(s.channels.at(channels::kImu).intact, 1);
  EXPECT_EQ(s.channels.at(channels::kImu).corrupt, 1);
  EXPECT_EQ(s.channels.at(channels::kStereo).received, 0);
}

TEST(LogComparator, IgnoresLcmSelfTest) {
  LoggedComparator logged(1);
  auto& cmp = logged.cmp;
  ASSERT_TRUE(cmp.ok());
  const uint8_t probe[4] = {'l', 'c', 'm', 0};
  cmp->onMessage("LCM_SELF_TEST", probe, sizeof probe);
  receive(*cmp, channels::kImu, encode(imu(0)));
  EXPECT_FALSE(cmp->allReceived());  // the stereo message is still due
  receive(*cmp, channels::kStereo, encode(stereo(0)));
  EXPECT_TRUE(cmp->allReceived());
  EXPECT_TRUE(cmp->summary().complete());
}

TEST(LogComparator, MissingLogIsAnErrorNamingIt) {
  const auto r = LogComparator::fromLog("/nonexistent/session.lcmlog");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("/nonexistent/session.lcmlog"), std::string::npos);
}

}  // namespace
}  // namespace evermap::messages
