// viewer/: what evermap-viewer makes of its messages (ViewerState, graphText), the board its
// web server reads (Board) and the JSON it writes (JsonWriter). The page itself is tested in a
// browser by tests/integration/viewer_browser.sh.

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <string>

#include "scratch_dir.h"
#include "viewer/board.h"
#include "viewer/json_writer.h"
#include "viewer/store_graph.h"
#include "viewer/viewer_state.h"

namespace evermap::viewer {
namespace {

map_node_t node(int64_t id, double x, int floor = 0, int session = 0) {
  map_node_t n{};
  n.node_id = id;
  n.position[0] = x;
  n.orientation[0] = 1.0;
  n.floor = floor;
  n.session = session;
  return n;
}

map_edge_t edge(int64_t a, int64_t b, int8_t type, int32_t count = 1) {
  map_edge_t e{};
  e.from_node = a;
  e.to_node = b;
  e.type = type;
  e.num_measurements = count;
  e.orientation[0] = 1.0;
  return e;
}

map_graph_t smallGraph() {
  map_graph_t g{};
  g.utime = 1000;
  g.nodes = {node(10, 0.0), node(11, 1.0), node(12, 2.0, 1, 1)};
  g.edges = {edge(10, 11, map_edge_t::TYPE_ODOMETRY), edge(11, 12, map_edge_t::TYPE_LOOP, 2),
             edge(11, 99, map_edge_t::TYPE_ODOMETRY)};
  g.floors = {map_floor_t{0, 0.0}, map_floor_t{1, 3.5}};
  g.num_nodes = 3;
  g.num_edges = 3;
  g.num_floors = 2;
  return g;
}

TEST(JsonWriter, EscapesStringsAndWritesNonFiniteNumbersAsNull) {
  JsonWriter j;
  j.beginObject().key("s").value("a\"b\\c\n\x01\xc3").key("v").beginArray();
  j.value(1.25, 2).value(NAN, 2).value(int64_t{-7}).value(true).endArray().endObject();
  EXPECT_EQ(j.take(), "{\"s\":\"a\\\"b\\\\c\\n\\u0001?\",\"v\":[1.25,null,-7,true]}");
}

TEST(Board, AClientGetsEveryTopicOnceThenOnlyNewerVersionsAndCountsWhatItSkipped) {
  Board board;
  board.post(Topic::kGraph, "g1");
  board.post(Topic::kPose, "p1");
  Board::Seen seen{};
  int last = -1;
  int got = 0;
  while (auto item = board.next(&seen, last)) {
    last = static_cast<int>(item->topic);
    ++got;
  }
  EXPECT_EQ(got, 2);
  for (int k = 2; k <= 5; ++k) board.post(Topic::kPose, std::to_string(k));
  auto item = board.next(&seen, last);
  ASSERT_TRUE(item.has_value());
  EXPECT_EQ(*item->text, "5");
  EXPECT_EQ(item->skipped, 3u);
  EXPECT_FALSE(board.next(&seen, last).has_value());
}

TEST(ViewerGraph, CountsNodesEdgesFloorsSessionsAndClosuresAndSkipsEdgesToUnknownNodes) {
  GraphSummary s;
  auto text = graphText(smallGraph(), "live", {}, &s);
  ASSERT_TRUE(text) << text.error().message;
  EXPECT_EQ(s.nodes, 3);
  EXPECT_EQ(s.edges, 2);
  EXPECT_EQ(s.edges_skipped, 1);
  EXPECT_EQ(s.floors, 2);
  EXPECT_EQ(s.sessions, 2);
  EXPECT_EQ(s.loop_edges, 1);
  EXPECT_EQ(s.closures, 2);
  EXPECT_NE(text->find("\"a\":[0,1],\"b\":[1,2],\"kind\":[0,1]"), std::string::npos) << *text;
}

TEST(ViewerGraph, RefusesANonFinitePositionAndADuplicateNodeIdAndKeepsThePreviousMap) {
  Board board;
  ViewerState state(board);
  ASSERT_TRUE(state.onGraph(smallGraph()));
  map_graph_t bad = smallGraph();
  bad.nodes[1].position[2] = INFINITY;
  EXPECT_FALSE(state.onGraph(bad));
  bad = smallGraph();
  bad.nodes[2].node_id = 10;
  const Status dup = state.onGraph(bad);
  ASSERT_FALSE(dup);
  EXPECT_NE(dup.error().message.find("node id 10 appears twice"), std::string::npos);
  EXPECT_EQ(board.version(Topic::kGraph), 1u);
  EXPECT_EQ(state.lastGraph().nodes, 3);
}

TEST(ViewerState, HistoryStaysBoundedOverALongRun) {
  Board board;
  ViewerStateOptions o;
  o.history_points = 100;
  ViewerState state(board, o);
  mapper_stats_t s{};
  s.component_names = {"solver"};
  s.component_ms = {1.0};
  s.num_components = 1;
  for (int k = 1; k <= 10000; ++k) {
    s.utime = k * 1000000LL;
    s.num_nodes = k;
    ASSERT_TRUE(state.onStats(s));
  }
  Board::Seen seen{};
  std::string history;
  while (auto item = board.next(&seen, -1))
    if (item->topic == Topic::kHistory) history = *item->text;
  const size_t points = std::count(history.begin(), history.end(), ',');
  EXPECT_LT(points, 3u * 100u);  // utime, nodes and one component column of < 100 points
  EXPECT_NE(history.find("\"utime\":[1000000,"), std::string::npos);  // still starts at the start
}

TEST(ViewerState, TheStatsTextCarriesTheMappersNamedCounters) {
  Board board;
  ViewerState state(board, ViewerStateOptions{});
  mapper_stats_t s{};
  s.utime = 1000000;
  s.counter_names = {"warm_restarts", "implausible_floors"};
  s.counter_values = {2, 7};
  s.num_counters = 2;
  ASSERT_TRUE(state.onStats(s));
  Board::Seen seen{};
  std::string stats;
  while (auto item = board.next(&seen, -1))
    if (item->topic == Topic::kStats) stats = *item->text;
  EXPECT_NE(stats.find("\"counters\":[[\"warm_restarts\",2],[\"implausible_floors\",7]]"),
            std::string::npos)
      << stats;
  // Names and values that do not pair up are refused.
  s.counter_values = {2};
  const Status bad = state.onStats(s);
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().message.find("2 counter names for 1 values"), std::string::npos)
      << bad.error().message;
}

TEST(ViewerState, DeputiesBeyondTheLimitAreRefused) {
  Board board;
  ViewerStateOptions o;
  o.max_hosts = 2;
  ViewerState state(board, o);
  deputy_status_t d{};
  for (const char* host : {"a", "b", "a"}) {
    d.host = host;
    EXPECT_TRUE(state.onDeputy(d));
  }
  d.host = "c";
  EXPECT_FALSE(state.onDeputy(d));
}

TEST(ViewerStore, AMissingStoreIsAnErrorNamingItAndNoFileIsCreated) {
  testing::ScratchDir dir;
  const auto file = dir.path() / "missing.db";
  auto loaded = loadStoredGraph(file);
  ASSERT_FALSE(loaded);
  EXPECT_NE(loaded.error().message.find("missing.db"), std::string::npos);
  EXPECT_FALSE(std::filesystem::exists(file));
}

TEST(ViewerStore, AFileThatIsNotAMapStoreIsAnErrorAndIsLeftUnchanged) {
  testing::ScratchDir dir;
  const auto file = dir.path() / "text.db";
  { std::ofstream(file) << "not sqlite"; }
  EXPECT_FALSE(loadStoredGraph(file));
  EXPECT_EQ(std::filesystem::file_size(file), 10u);
}

}  // namespace
}  // namespace evermap::viewer
