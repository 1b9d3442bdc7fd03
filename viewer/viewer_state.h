#pragma once
// What the viewer makes of the messages it receives (DESIGN.md section 1: "a viewer only
// listens"): each handler checks its message, turns it into the JSON text the page reads and
// posts it on the Board (board.h). Nothing here knows LCM or HTTP, so the tests call it
// directly and the offline mode (--store) feeds it the stored map through the same path.
//
// A message that fails a check (a position that is not finite, an edge to no node, too many
// hosts) is refused with an Error naming the field; the caller counts it (the Inbox does)
// and the previous text of the topic stays on the board.
//
// Memory is bounded whatever arrives: one text per topic, the nodes-against-time history at
// most Options::history_points points (halved when full), at most Options::max_hosts deputies.
//
// The JSON texts ({"type": TOPIC, ...}) are documented in docs/viewer.md.
// Threading: one thread (the LCM loop, or main in offline mode).

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include <evermap/deputy_status_t.hpp>
#include <evermap/floor_t.hpp>
#include <evermap/keyframe_t.hpp>
#include <evermap/map_graph_t.hpp>
#include <evermap/mapper_stats_t.hpp>
#include <evermap/pose_t.hpp>
#include <evermap/register_result_t.hpp>
#include <evermap/vo_delta_t.hpp>

#include "core/common/expected.h"
#include "viewer/board.h"

namespace evermap::viewer {

struct ViewerStateOptions {
  // Points of the nodes-against-time plot kept; when full, every other one is dropped.
  int history_points = 2000;
  // Deputies (hosts) shown; DEPUTY_STATUS of a further host is refused.
  int max_hosts = 32;
  // Positions beyond this (metres, any axis) are refused: a map is not 1000 km wide.
  double max_coordinate_m = 1e6;
  // KEYFRAME features sent with the image, at most.
  int max_features = 2000;

  Status validate() const;
};

// "graph" text of a map (also what --store shows); `source` is "live" or the store's path.
// Errors: a non-finite or absurd position, a duplicate node id.
struct GraphSummary {
  int64_t nodes = 0, edges = 0, floors = 0, sessions = 0;
  int64_t loop_edges = 0;     // edges of TYPE_LOOP
  int64_t closures = 0;       // accepted loop constraints (num_measurements of loop edges)
  int64_t edges_skipped = 0;  // edges naming a node the graph does not hold
};
Expected<std::string> graphText(const map_graph_t& g, const std::string& source,
                                const ViewerStateOptions& options, GraphSummary* summary = nullptr);

class ViewerState {
 public:
  // `board` must outlive the state.
  ViewerState(Board& board, const ViewerStateOptions& options = {});

  Status onGraph(const map_graph_t& msg, const std::string& source = "live");
  Status onPose(const pose_t& msg);
  Status onFloor(const floor_t& msg);
  Status onStats(const mapper_stats_t& msg);
  Status onRegister(const register_result_t& msg);
  Status onDeputy(const deputy_status_t& msg);
  Status onVo(const vo_delta_t& msg);
  // Keeps the features for the next image (image_feed.h posts them with it).
  Status onKeyframe(const keyframe_t& msg);

  // The latest KEYFRAME's features as a JSON array [u, v, u, v, ...] and its utime (-1: none).
  const std::string& featuresJson() const { return features_json_; }
  int64_t featuresUtime() const { return features_utime_; }
  const GraphSummary& lastGraph() const { return last_graph_; }
  int64_t graphs() const { return graphs_; }

 private:
  void postHistory();

  Board& board_;
  ViewerStateOptions o_;
  GraphSummary last_graph_;
  int64_t graphs_ = 0;
  // Nodes against message time (MAPPER_STATS): one row per kept point.
  struct HistoryPoint {
    int64_t utime;
    int64_t nodes;
    std::vector<std::pair<std::string, double>> component_ms;
  };
  std::vector<HistoryPoint> history_;
  int64_t history_stride_ = 1;  // keep one MAPPER_STATS in this many (doubles when full)
  int64_t history_seen_ = 0;
  // REGISTER_RESULT counts by status.
  std::map<int, int64_t> register_counts_;
  // DEPUTY_STATUS per host: its text.
  std::map<std::string, std::string> hosts_;
  std::string features_json_ = "[]";
  int64_t features_utime_ = -1;
};

}  // namespace evermap::viewer
