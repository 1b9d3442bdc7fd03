// viewer/log_player.h: `evermap-viewer --log` plays the viewer's channels of a log in order;
// a stretch skipped by a seek sends only the last MAP_GRAPH and the trail's POSEs.

#include <gtest/gtest.h>

#include <map>
#include <string>

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
    put("STEREO", t);  // not a channel the player keeps here
  }
}

TEST(ViewerLogPlayer, ASkippedStretchSendsTheLastMapAndTheTrailAndEverythingElse) {
  testing::ScratchDir dir;
  const auto file = dir.path() / "run.lcmlog";
  writeLog(file);
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

TEST(ViewerLogPlayer, AMissingLogIsAnErrorNamingIt) {
  auto player = LogPlayer::open("/nonexistent/run.lcmlog", {"POSE"});
  ASSERT_FALSE(player);
  EXPECT_NE(player.error().message.find("/nonexistent/run.lcmlog"), std::string::npos);
}

}  // namespace
}  // namespace evermap::viewer
