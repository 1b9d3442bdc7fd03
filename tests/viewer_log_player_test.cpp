// viewer/log_player.h: `evermap-viewer --log` plays the viewer's channels of a log in order;
// a stretch skipped by a seek sends only the last MAP_GRAPH and the trail's POSEs.

#include <gtest/gtest.h>

#include <map>
#include <string>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "scratch_dir.h"
#include "viewer/log_player.h"

namespace evermap::viewer {
namespace {

void writeLog(const std::filesystem::path& file) {
  lcm::LogFile log(file.string(), "w");
  ASSERT_TRUE(log.good());
  int64_t n = 0;
  auto put = [&](const std::string& channel, int64_t t) {
    lcm::LogEvent e;
    e.eventnum = n++;
    e.timestamp = t;
    e.channel = channel;
    std::string data = channel + std::to_string(t);
    e.datalen = static_cast<int32_t>(data.size());
    e.data = data.data();
    ASSERT_EQ(log.writeEvent(&e), 0);
  };
  for (int64_t t = 1000; t <= 10000; t += 10) {
    put("POSE", t);
    if (t % 1000 == 0) put("MAP_GRAPH", t);
    if (t % 500 == 0) put("MAPPER_STATS", t);
    if (t % 250 == 0) put("KEYFRAME", t);
    put("STEREO", t);  // kept only when asked for, one per image period
  }
}

// Each test plays the same log of writeLog.
class ViewerLogPlayer : public ::testing::Test {
 protected:
  void SetUp() override { ASSERT_NO_FATAL_FAILURE(writeLog(file)); }
  testing::ScratchDir dir;
  const std::filesystem::path file = dir.path() / "run.lcmlog";
};

TEST_F(ViewerLogPlayer, ASkippedStretchSendsTheLastMapAndTheTrailAndEverythingElse) {
  LogPlayerOptions o;
  o.trail_poses = 50;
  auto player = LogPlayer::open(file, {"POSE", "MAP_GRAPH", "MAPPER_STATS"}, o);
  ASSERT_TRUE(player) << player.error().message;
  EXPECT_EQ(player->startUtime(), 1000);
  EXPECT_EQ(player->endUtime(), 10000);
  std::map<std::string, int> sent;
  std::string last_graph;
  auto count = [&](const std::string& channel, const void* data, size_t size) {
    ++sent[channel];
    if (channel == "MAP_GRAPH") last_graph.assign(static_cast<const char*>(data), size);
  };
  player->playTo(5000, count);
  EXPECT_EQ(sent["MAP_GRAPH"], 1);
  EXPECT_EQ(last_graph, "MAP_GRAPH5000");
  EXPECT_EQ(sent["POSE"], 50);
  EXPECT_EQ(sent["MAPPER_STATS"], 9);
  EXPECT_EQ(sent.count("STEREO"), 0u);
  EXPECT_EQ(player->position(), 5000);
  // Playing on in small steps sends every message.
  sent.clear();
  for (int64_t t = 5010; t <= 6000; t += 10) player->playTo(t, count);
  EXPECT_EQ(sent["POSE"], 100);
  EXPECT_EQ(sent["MAP_GRAPH"], 1);
  // Back to the start.
  player->rewind();
  sent.clear();
  player->playTo(1000, count);
  EXPECT_EQ(sent["POSE"], 1);
  EXPECT_EQ(sent["MAP_GRAPH"], 1);
}

TEST_F(ViewerLogPlayer, CameraImagesAreKeptOnePerPeriodEachWithTheNewestKeyframeBeforeIt) {
  LogPlayerOptions o;
  o.image_period_us = 1000;
  auto player = LogPlayer::open(file, {"POSE", "STEREO", "KEYFRAME"}, o);
  ASSERT_TRUE(player) << player.error().message;
  EXPECT_EQ(player->images(), 10);  // 1000, 2000, ..., 10000
  std::vector<std::string> images;
  auto collect = [&](const std::string& channel, const void* data, size_t size) {
    if (channel != "POSE") images.emplace_back(static_cast<const char*>(data), size);
  };
  for (int64_t t = 1000; t <= 10000; t += 10) player->playTo(t, collect);
  ASSERT_EQ(images.size(), 20u);
  EXPECT_EQ(images[0], "KEYFRAME1000");
  EXPECT_EQ(images[1], "STEREO1000");
  EXPECT_EQ(images[18], "KEYFRAME10000");
  EXPECT_EQ(images[19], "STEREO10000");
  // A stretch played at once sends its last image and keyframe only.
  player->rewind();
  images.clear();
  player->playTo(10000, collect);
  EXPECT_EQ(images, (std::vector<std::string>{"KEYFRAME10000", "STEREO10000"}));
}

TEST_F(ViewerLogPlayer, ImagesBeyondTheirBudgetAreThinnedNotRefused) {
  LogPlayerOptions o;
  o.image_period_us = 1000;
  o.max_image_bytes = 100;  // about four images with their keyframes ("KEYFRAME1000STEREO1000")
  auto player = LogPlayer::open(file, {"STEREO", "KEYFRAME"}, o);
  ASSERT_TRUE(player) << player.error().message;
  EXPECT_GE(player->images(), 2);
  EXPECT_LE(player->images(), 4);
  EXPECT_GT(player->imagePeriodUs(), 1000);
  int64_t bytes = 0;
  player->rewind();
  for (int64_t t = 1000; t <= 10000; t += 10)
    player->playTo(t, [&](const std::string&, const void*, size_t size) {
      bytes += static_cast<int64_t>(size);
    });
  EXPECT_LE(bytes, 100);
  // Without KEYFRAME asked for, images come alone.
  auto alone = LogPlayer::open(file, {"STEREO"}, o);
  ASSERT_TRUE(alone);
  EXPECT_EQ(alone->events(), static_cast<size_t>(alone->images()));
}

TEST_F(ViewerLogPlayer, AMissingLogIsAnErrorNamingIt) {
  auto player = LogPlayer::open("/nonexistent/run.lcmlog", {"POSE"});
  ASSERT_FALSE(player);
  EXPECT_NE(player.error().message.find("/nonexistent/run.lcmlog"), std::string::npos);
}

TEST_F(ViewerLogPlayer, ThePagesCommandsAreParsedAndAnythingElseIsNothing) {
  using Kind = LogCommand::Kind;
  ASSERT_TRUE(parseLogCommand("play"));
  EXPECT_EQ(parseLogCommand("play")->kind, Kind::kPlay);
  EXPECT_EQ(parseLogCommand("pause")->kind, Kind::kPause);
  const auto seek = parseLogCommand("seek 1700000000123456");
  ASSERT_TRUE(seek);
  EXPECT_EQ(seek->kind, Kind::kSeek);
  EXPECT_EQ(seek->utime, 1700000000123456);
  const auto speed = parseLogCommand("speed 2.5");
  ASSERT_TRUE(speed);
  EXPECT_EQ(speed->kind, Kind::kSpeed);
  EXPECT_DOUBLE_EQ(speed->speed, 2.5);
  EXPECT_DOUBLE_EQ(parseLogCommand("speed 1000")->speed, kMaxLogSpeed);
  EXPECT_DOUBLE_EQ(parseLogCommand("speed 0.01")->speed, kMinLogSpeed);
  // The page is untrusted: partial numbers, non-finite or out-of-range speeds, other words.
  for (const char* text :
       {"",           "a",         "Play",      "play ",    "seek",
        "seek ",      "seek 12x",  "seek x12",  "seek 1e3", "seek 99999999999999999999",
        "speed",      "speed ",    "speed 0",   "speed -1", "speed 0.001",
        "speed 1001", "speed inf", "speed nan", "speed 2 ", "speed 2x",
        "speeds 2",   "stop"})
    EXPECT_FALSE(parseLogCommand(text)) << "'" << text << "'";
}

}  // namespace
}  // namespace evermap::viewer
