#include "viewer/viewer_state.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <set>
#include <unordered_map>

#include "core/common/finite.h"
#include "viewer/json_writer.h"

namespace evermap::viewer {
namespace {

// Wall-clock milliseconds since the epoch, stamped on a graph text so the page can measure
// the latency from the viewer to its pixels (measurement only).
int64_t wallMs() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

const char* registerStatusName(int s) {
  switch (s) {
    case register_result_t::STATUS_OK:
      return "ok";
    case register_result_t::STATUS_NO_CANDIDATE:
      return "no_candidate";
    case register_result_t::STATUS_TOO_FEW_INLIERS:
      return "too_few_inliers";
    case register_result_t::STATUS_UNKNOWN_NODE:
      return "unknown_node";
    case register_result_t::STATUS_UNKNOWN_KEYFRAME:
      return "unknown_keyframe";
    case register_result_t::STATUS_MALFORMED:
      return "malformed";
    case register_result_t::STATUS_STALE:
      return "stale";
  }
  return "other";
}

const char* voStatusName(int s) {
  switch (s) {
    case vo_delta_t::STATUS_OK:
      return "ok";
    case vo_delta_t::STATUS_NO_DATA:
      return "no_data";
    case vo_delta_t::STATUS_INSUFFICIENT_FEATURES:
      return "insufficient_features";
    case vo_delta_t::STATUS_INSUFFICIENT_INLIERS:
      return "insufficient_inliers";
    case vo_delta_t::STATUS_OPTIMIZATION_FAILURE:
      return "optimization_failure";
    case vo_delta_t::STATUS_REPROJECTION_ERROR:
      return "reprojection_error";
    case vo_delta_t::STATUS_BAD_INPUT:
      return "bad_input";
  }
  return "other";
}

const char* procStateName(int s) {
  switch (s) {
    case deputy_proc_t::STATE_STOPPED:
      return "stopped";
    case deputy_proc_t::STATE_RUNNING:
      return "running";
    case deputy_proc_t::STATE_RESTARTING:
      return "restarting";
    case deputy_proc_t::STATE_FAILED:
      return "failed";
  }
  return "other";
}

// A string from a message, cut to `max` bytes for the page.
std::string clip(const std::string& s, size_t max = 200) {
  return s.size() <= max ? s : s.substr(0, max) + "...";
}

}  // namespace

Status ViewerStateOptions::validate() const {
  if (history_points < 2) return makeError("history_points: must be >= 2, got ", history_points);
  if (max_hosts < 1) return makeError("max_hosts: must be >= 1, got ", max_hosts);
  if (!(max_coordinate_m > 0.0))
    return makeError("max_coordinate_m: must be > 0, got ", max_coordinate_m);
  if (max_features < 0) return makeError("max_features: must be >= 0, got ", max_features);
  return Ok{};
}

namespace {

// The graph's nodes checked (finite, within max_coordinate_m, ids unique): node id -> position
// in the arrays; the sessions and floors of the nodes into `sessions` and `floors`.
Expected<std::unordered_map<int64_t, int64_t>> indexNodes(const map_graph_t& g,
                                                          const ViewerStateOptions& o,
                                                          std::set<int>* sessions,
                                                          std::set<int>* floors) {
  std::unordered_map<int64_t, int64_t> index;
  index.reserve(g.nodes.size());
  for (size_t k = 0; k < g.nodes.size(); ++k) {
    const map_node_t& n = g.nodes[k];
    if (!allFinite(n.position, 3))
      return makeError("MAP_GRAPH: node ", n.node_id, ": position is not finite");
    for (double v : n.position)
      if (std::abs(v) > o.max_coordinate_m)
        return makeError("MAP_GRAPH: node ", n.node_id, ": position ", v, " m beyond ",
                         o.max_coordinate_m, " m");
    if (!index.emplace(n.node_id, static_cast<int64_t>(k)).second)
      return makeError("MAP_GRAPH: node id ", n.node_id, " appears twice");
    sessions->insert(n.session);
    floors->insert(n.floor);
  }
  for (const map_floor_t& f : g.floors)
    if (!std::isfinite(f.height_m))
      return makeError("MAP_GRAPH: floor ", f.index, ": height is not finite");
  return index;
}

void writeNodes(const map_graph_t& g, JsonWriter& j) {
  j.key("nodes").beginObject();
  j.key("id").beginArray();
  for (const map_node_t& n : g.nodes) j.value(n.node_id);
  j.endArray().key("xyz").beginArray();
  for (const map_node_t& n : g.nodes)
    for (double v : n.position) j.value(v, 3);
  j.endArray().key("floor").beginArray();
  for (const map_node_t& n : g.nodes) j.value(n.floor);
  j.endArray().key("session").beginArray();
  for (const map_node_t& n : g.nodes) j.value(n.session);
  j.endArray().key("utime").beginArray();
  for (const map_node_t& n : g.nodes) j.value(n.keyframe_utime);
  j.endArray().endObject();
}

// Edges by the positions of their nodes in the node arrays; those with a missing node are
// skipped (counted in `s`, as loop edges and closures).
void writeEdges(const map_graph_t& g, const std::unordered_map<int64_t, int64_t>& index,
                JsonWriter& j, GraphSummary* s) {
  j.key("edges").beginObject();
  std::vector<int64_t> a, b;
  std::vector<int> kind, count;
  a.reserve(g.edges.size());
  for (const map_edge_t& e : g.edges) {
    const auto i = index.find(e.from_node), k = index.find(e.to_node);
    if (i == index.end() || k == index.end()) {
      ++s->edges_skipped;
      continue;
    }
    a.push_back(i->second);
    b.push_back(k->second);
    kind.push_back(e.type);
    count.push_back(e.num_measurements);
    if (e.type == map_edge_t::TYPE_LOOP) {
      ++s->loop_edges;
      s->closures += std::max(0, e.num_measurements);
    }
  }
  j.key("a").beginArray();
  for (int64_t v : a) j.value(v);
  j.endArray().key("b").beginArray();
  for (int64_t v : b) j.value(v);
  j.endArray().key("kind").beginArray();
  for (int v : kind) j.value(v);
  j.endArray().key("n").beginArray();
  for (int v : count) j.value(v);
  j.endArray().endObject();
  s->edges = static_cast<int64_t>(a.size());
}

}  // namespace

Expected<std::string> graphText(const map_graph_t& g, const std::string& source,
                                const ViewerStateOptions& o, GraphSummary* summary) {
  GraphSummary s;
  std::set<int> sessions, floors;
  auto index = indexNodes(g, o, &sessions, &floors);
  if (!index) return index.error();
  JsonWriter j;
  j.beginObject().key("type").value("graph").key("source").value(source);
  j.key("utime").value(g.utime).key("built_ms").value(wallMs());
  writeNodes(g, j);
  writeEdges(g, *index, j, &s);
  j.key("floors").beginArray();
  for (const map_floor_t& f : g.floors) {
    j.beginObject().key("index").value(f.index).key("height_m").value(f.height_m, 3).endObject();
    floors.insert(f.index);
  }
  j.endArray();
  s.nodes = static_cast<int64_t>(g.nodes.size());
  s.floors = static_cast<int64_t>(floors.size());
  s.sessions = static_cast<int64_t>(sessions.size());
  j.key("counts").beginObject();
  j.key("nodes").value(s.nodes).key("edges").value(s.edges).key("floors").value(s.floors);
  j.key("sessions").value(s.sessions).key("loop_edges").value(s.loop_edges);
  j.key("closures").value(s.closures).key("edges_skipped").value(s.edges_skipped);
  j.endObject().endObject();
  if (summary) *summary = s;
  return j.take();
}

ViewerState::ViewerState(Board& board, const ViewerStateOptions& options)
    : board_(board), o_(options) {}

Status ViewerState::onGraph(const map_graph_t& msg, const std::string& source) {
  GraphSummary s;
  auto text = graphText(msg, source, o_, &s);
  if (!text) return text.error();
  board_.post(Topic::kGraph, std::move(*text));
  last_graph_ = s;
  ++graphs_;
  return Ok{};
}

Status ViewerState::onPose(const pose_t& msg) {
  if (!allFinite(msg.position, 3) || !allFinite(msg.orientation, 4))
    return makeError("POSE ", msg.utime, ": position or orientation is not finite");
  for (double v : msg.position)
    if (std::abs(v) > o_.max_coordinate_m)
      return makeError("POSE ", msg.utime, ": position ", v, " m is absurd");
  JsonWriter j;
  j.beginObject().key("type").value("pose").key("utime").value(msg.utime);
  j.key("xyz").beginArray();
  for (double v : msg.position) j.value(v, 3);
  j.endArray().key("q").beginArray();
  for (double v : msg.orientation) j.value(v, 5);
  j.endArray();
  // 1-sigma of the horizontal position (the trace of the x-y block), for the page's label.
  const double var_xy = msg.covariance[0] + msg.covariance[7];
  j.key("sigma_xy_m").value(var_xy >= 0.0 ? std::sqrt(var_xy) : NAN, 3);
  j.key("floor").value(msg.floor).key("session").value(msg.session).endObject();
  board_.post(Topic::kPose, j.take());
  return Ok{};
}

Status ViewerState::onFloor(const floor_t& msg) {
  if (!std::isfinite(msg.height_m)) return makeError("FLOOR ", msg.utime, ": height is not finite");
  JsonWriter j;
  j.beginObject().key("type").value("floor").key("utime").value(msg.utime);
  j.key("floor_index").value(msg.floor_index).key("height_m").value(msg.height_m, 2);
  j.key("in_elevator").value(msg.in_elevator != 0).key("event").value(static_cast<int>(msg.event));
  j.key("new_floor").value(msg.new_floor != 0).endObject();
  board_.post(Topic::kFloor, j.take());
  return Ok{};
}

Status ViewerState::onStats(const mapper_stats_t& msg) {
  if (msg.component_ms.size() != msg.component_names.size())
    return makeError("MAPPER_STATS ", msg.utime, ": ", msg.component_names.size(), " names for ",
                     msg.component_ms.size(), " times");
  if (msg.counter_values.size() != msg.counter_names.size())
    return makeError("MAPPER_STATS ", msg.utime, ": ", msg.counter_names.size(),
                     " counter names for ", msg.counter_values.size(), " values");
  JsonWriter j;
  j.beginObject().key("type").value("stats").key("utime").value(msg.utime);
  j.key("nodes")
      .value(static_cast<int64_t>(msg.num_nodes))
      .key("edges")
      .value(static_cast<int64_t>(msg.num_edges));
  j.key("floors")
      .value(static_cast<int64_t>(msg.num_floors))
      .key("sessions")
      .value(static_cast<int64_t>(msg.num_sessions));
  j.key("constraints").value(msg.num_constraints).key("rejected").value(msg.num_rejected);
  j.key("dropped").value(msg.num_dropped_messages);
  j.key("components").beginArray();
  for (size_t k = 0; k < msg.component_names.size(); ++k)
    j.beginArray().value(clip(msg.component_names[k], 40)).value(msg.component_ms[k], 3).endArray();
  j.endArray();
  j.key("counters").beginArray();
  for (size_t k = 0; k < msg.counter_names.size() && k < 64; ++k)
    j.beginArray().value(clip(msg.counter_names[k], 40)).value(msg.counter_values[k]).endArray();
  j.endArray().endObject();
  board_.post(Topic::kStats, j.take());

  // The history keeps one MAPPER_STATS in history_stride_; when full, every other point goes
  // and the stride doubles, so the plot covers the whole run in bounded memory. A mapper with
  // no message yet says utime -1, and a stamp older than the last point (a log replayed again)
  // would fold the plot back: neither is a point.
  const bool in_order = msg.utime > 0 && (history_.empty() || msg.utime >= history_.back().utime);
  if (in_order && history_seen_++ % history_stride_ == 0) {
    HistoryPoint p{msg.utime, msg.num_nodes, {}};
    for (size_t k = 0; k < msg.component_names.size() && k < 16; ++k)
      p.component_ms.emplace_back(clip(msg.component_names[k], 40), msg.component_ms[k]);
    history_.push_back(std::move(p));
    if (static_cast<int>(history_.size()) >= o_.history_points) {
      std::vector<HistoryPoint> kept;
      for (size_t k = 0; k < history_.size(); k += 2) kept.push_back(std::move(history_[k]));
      history_ = std::move(kept);
      history_stride_ *= 2;
    }
  }
  postHistory();
  return Ok{};
}

void ViewerState::postHistory() {
  JsonWriter j;
  j.beginObject().key("type").value("history").key("stride").value(history_stride_);
  j.key("utime").beginArray();
  for (const HistoryPoint& p : history_) j.value(p.utime);
  j.endArray().key("nodes").beginArray();
  for (const HistoryPoint& p : history_) j.value(p.nodes);
  j.endArray();
  // One column per component name seen, null where a point lacks it.
  std::vector<std::string> names;
  for (const HistoryPoint& p : history_)
    for (const auto& [name, ms] : p.component_ms)
      if (std::find(names.begin(), names.end(), name) == names.end() && names.size() < 16)
        names.push_back(name);
  j.key("components").beginObject();
  for (const std::string& name : names) {
    j.key(name).beginArray();
    for (const HistoryPoint& p : history_) {
      double v = NAN;
      for (const auto& [n, ms] : p.component_ms)
        if (n == name) v = ms;
      j.value(v, 3);
    }
    j.endArray();
  }
  j.endObject().endObject();
  board_.post(Topic::kHistory, j.take());
}

Status ViewerState::onRegister(const register_result_t& msg) {
  ++register_counts_[msg.status];
  JsonWriter j;
  j.beginObject().key("type").value("register");
  int64_t ok = 0, failed = 0;
  j.key("by_status").beginObject();
  for (const auto& [status, n] : register_counts_) {
    (status == register_result_t::STATUS_OK ? ok : failed) += n;
    j.key(registerStatusName(status)).value(n);
  }
  j.endObject().key("ok").value(ok).key("failed").value(failed);
  j.key("last").beginObject().key("utime").value(msg.utime).key("status").value(
      registerStatusName(msg.status));
  j.key("node_id").value(msg.node_id).key("inliers").value(static_cast<int64_t>(msg.num_inliers));
  j.key("score").value(msg.score, 3).key("reason").value(clip(msg.reason)).endObject().endObject();
  board_.post(Topic::kRegister, j.take());
  return Ok{};
}

Status ViewerState::onDeputy(const deputy_status_t& msg) {
  const std::string host = clip(msg.host, 64);
  if (!hosts_.count(host) && static_cast<int>(hosts_.size()) >= o_.max_hosts)
    return makeError("DEPUTY_STATUS: host \"", host, "\": already ", o_.max_hosts, " hosts shown");
  JsonWriter h;
  h.beginObject().key("host").value(host).key("utime").value(msg.utime).key("procs").beginArray();
  for (const deputy_proc_t& p : msg.procs) {
    h.beginObject().key("name").value(clip(p.name, 64)).key("group").value(clip(p.group, 64));
    h.key("state")
        .value(procStateName(p.state))
        .key("desired_running")
        .value(p.desired_running != 0);
    h.key("pid")
        .value(static_cast<int64_t>(p.pid))
        .key("restarts")
        .value(static_cast<int64_t>(p.restarts));
    h.key("last_exit_code").value(static_cast<int64_t>(p.last_exit_code));
    h.key("cpu_percent").value(p.cpu_percent, 1).key("rss_bytes").value(p.rss_bytes).endObject();
  }
  h.endArray().endObject();
  hosts_[host] = h.take();
  std::string text = "{\"type\":\"deputy\",\"hosts\":[";
  bool first = true;
  for (const auto& [name, t] : hosts_) {
    if (!first) text += ',';
    first = false;
    text += t;
  }
  text += "]}";
  board_.post(Topic::kDeputy, std::move(text));
  return Ok{};
}

Status ViewerState::onVo(const vo_delta_t& msg) {
  JsonWriter j;
  j.beginObject().key("type").value("vo").key("utime").value(msg.utime);
  j.key("status")
      .value(voStatusName(msg.status))
      .key("keyframe_changed")
      .value(msg.keyframe_changed != 0);
  j.key("features").value(static_cast<int64_t>(msg.num_features));
  j.key("matches").value(static_cast<int64_t>(msg.num_matches));
  j.key("inliers").value(static_cast<int64_t>(msg.num_inliers)).endObject();
  board_.post(Topic::kVo, j.take());
  return Ok{};
}

Status ViewerState::onKeyframe(const keyframe_t& msg) {
  if (msg.keypoints.size() != static_cast<size_t>(std::max(0, msg.num_features)))
    return makeError("KEYFRAME ", msg.utime, ": ", msg.keypoints.size(),
                     " keypoints for num_features ", msg.num_features);
  JsonWriter j;
  j.beginArray();
  const size_t n = std::min(msg.keypoints.size(), static_cast<size_t>(o_.max_features));
  for (size_t k = 0; k < n; ++k) {
    j.value(static_cast<double>(msg.keypoints[k][0]), 1);
    j.value(static_cast<double>(msg.keypoints[k][1]), 1);
  }
  j.endArray();
  features_json_ = j.take();
  features_utime_ = msg.utime;
  return Ok{};
}

}  // namespace evermap::viewer
