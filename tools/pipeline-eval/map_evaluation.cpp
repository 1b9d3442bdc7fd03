#include "tools/pipeline-eval/map_evaluation.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <limits>
#include <set>
#include <sstream>

#include "core/common/key_value_file.h"
#include "core/messages/channels.h"
#include "core/messages/convert.h"
#include "core/messages/pose_fields.h"
#include "mapper-proc/map_store.h"
#include "tools/eval/alignment.h"
#include "tools/eval/metrics.h"
#include "tools/eval/trajectory.h"
#include "tools/lcmlog/log_reader.h"

namespace evermap::mapper {
namespace {

Expected<core::SE3d> poseOf(const double* t, const double* q, const std::string& what) {
  const Expected<Eigen::Quaterniond> quat = messages::quaternionFromMessage(q, what.c_str());
  if (!quat) return quat.error();
  if (!std::isfinite(t[0]) || !std::isfinite(t[1]) || !std::isfinite(t[2]))
    return makeError(what, ": position is not finite");
  return core::SE3d(quat->normalized(), core::Vec3(t[0], t[1], t[2]));
}

// SE(3)-aligned ATE of est against gt (paired by index).
Expected<eval::ErrorStats> alignedAte(const std::vector<core::SE3d>& gt,
                                      std::vector<core::SE3d> est) {
  auto aligned = eval::alignTrajectories(gt, est, eval::AlignmentMode::kSE3);
  if (!aligned) return aligned.error();
  for (auto& e : est) e = aligned->gt_S_est * e;
  auto ate = eval::computeAte(gt, est);
  if (!ate) return ate.error();
  return ate->translation_m;
}

}  // namespace

Expected<EvalMap> mapFromGraph(const map_graph_t& g) {
  EvalMap m;
  for (const map_node_t& n : g.nodes) {
    auto pose = poseOf(n.position, n.orientation, "MAP_GRAPH node " + std::to_string(n.node_id));
    if (!pose) return pose.error();
    m.nodes.push_back(EvalNode{n.node_id, n.keyframe_utime, *pose, n.floor, n.session});
  }
  m.edges = static_cast<int64_t>(g.edges.size());
  for (const map_edge_t& e : g.edges) {
    if (e.type != map_edge_t::TYPE_LOOP) continue;
    ++m.loop_edges;
    auto pose =
        poseOf(e.translation, e.orientation, "MAP_GRAPH edge " + std::to_string(e.from_node));
    if (!pose) return pose.error();
    m.loops.push_back(EvalLoop{e.from_node, e.to_node, *pose});
  }
  for (const map_floor_t& f : g.floors) {
    if (!std::isfinite(f.height_m))
      return makeError("MAP_GRAPH floor ", f.index, ": height is not finite");
    m.floors[f.index] = f.height_m;
  }
  return m;
}

Expected<EvalMap> mapFromStore(const std::filesystem::path& file) {
  if (!std::filesystem::exists(file)) return makeError(file.string(), ": no such map store");
  auto store = MapStore::open(file, MapStoreOptions{.read_only = true});
  if (!store) return store.error();
  auto snap = store->load();
  if (!snap) return snap.error();
  EvalMap m;
  for (const StoredNode& n : snap->nodes)
    m.nodes.push_back(
        EvalNode{n.node.id, n.node.keyframe_utime, n.world_T_body, n.node.floor, n.node.session});
  std::set<std::pair<int64_t, int64_t>> pairs, loops;
  for (const StoredEdge& e : snap->edges) {
    if (!e.constraint.accepted) continue;
    const auto key = std::minmax(e.constraint.from, e.constraint.to);
    pairs.insert(key);
    if (e.constraint.kind == ConstraintKind::kLoop) loops.insert(key);
  }
  m.edges = static_cast<int64_t>(pairs.size());
  m.loop_edges = static_cast<int64_t>(loops.size());
  for (const auto& [index, height] : snap->floors) m.floors[index] = height;
  return m;
}

Expected<RecordedRun> readRecordedRun(const std::filesystem::path& file) {
  auto opened = messages::LogReader::open(file);
  if (!opened) return opened.error();
  messages::LogReader& log = *opened;
  RecordedRun r;
  std::optional<map_graph_t> last_graph;
  while (const messages::LogReader::Event* ev = log.next()) {
    const std::string channel = ev->channel;
    if (channel == channels::kMapGraph) {
      auto g = messages::decodeLcm<map_graph_t>(ev->data, ev->datalen, channel);
      if (!g) {
        ++r.undecodable;
        continue;
      }
      last_graph = std::move(*g);
      ++r.graphs;
    } else if (channel == channels::kMapperStats) {
      auto s = messages::decodeLcm<mapper_stats_t>(ev->data, ev->datalen, channel);
      if (!s) {
        ++r.undecodable;
        continue;
      }
      r.stats = *s;
      r.have_stats = true;
    } else if (channel == channels::kPose) {
      auto p = decodeLoggedPose(*ev);
      if (!p) {
        ++r.undecodable;
        continue;
      }
      r.poses.emplace_back(p->msg.utime, p->world_T_body);
    }
  }
  // Cut mid-event: the last MAP_GRAPH read is not the run's last map.
  if (Status s = log.status(); !s) return s.error();
  if (!last_graph) return makeError(file.string(), ": no MAP_GRAPH message in the log");
  auto map = mapFromGraph(*last_graph);
  if (!map) return makeError(file.string(), ": ", map.error().message);
  r.map = std::move(*map);
  return r;
}

Expected<LoggedPose> decodeLoggedPose(const messages::LogReader::Event& ev) {
  auto m = messages::decodeLcm<pose_t>(ev.data, ev.datalen, ev.channel);
  if (!m) return m.error();
  auto pose = messages::fromMsg(*m);
  if (!pose) return pose.error();
  return LoggedPose{*m, pose->mean};
}

bool RunTruth::at(int64_t utime, core::SE3d* out) const {
  constexpr int64_t kMaxGap = 250000;
  auto hi = world_T_body.lower_bound(utime);
  if (hi != world_T_body.end() && hi->first == utime) {
    *out = hi->second;
    return true;
  }
  if (hi == world_T_body.end() || hi == world_T_body.begin()) return false;
  auto lo = std::prev(hi);
  if (utime - lo->first > kMaxGap || hi->first - utime > kMaxGap) return false;
  const double a =
      static_cast<double>(utime - lo->first) / static_cast<double>(hi->first - lo->first);
  const core::Vec3 t = (1 - a) * lo->second.translation() + a * hi->second.translation();
  *out = core::SE3d(a < 0.5 ? lo->second.so3() : hi->second.so3(), t);
  return true;
}

int RunTruth::floorAt(double z_m) const {
  int best = -1;
  double best_d = 1e300;
  for (const auto& [index, height] : floors) {
    if (std::abs(z_m - height) < best_d) {
      best_d = std::abs(z_m - height);
      best = index;
    }
  }
  return best;
}

Expected<RunTruth> readRunTruth(const std::filesystem::path& folder) {
  RunTruth truth;
  const auto sidecar = folder / "run.sim.txt";
  auto file = KeyValueFile::load(sidecar);
  if (!file) return file.error();
  for (const auto& e : file->entries()) {
    int index = 0;
    char rest[16] = {};
    if (std::sscanf(e.key.c_str(), "meta.floor.%d.%15s", &index, rest) == 2 &&
        std::string(rest) == "height_m") {
      truth.floors[index] = std::atof(e.value.c_str());
    } else if (e.key.rfind("meta.session.", 0) == 0) {
      ++truth.sessions;
    }
  }
  if (truth.floors.empty())
    return makeError(sidecar.string(), ": no meta.floor.*.height_m lines (not a run sidecar?)");
  std::vector<std::filesystem::path> tums;
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(folder, ec))
    if (entry.path().extension() == ".tum") tums.push_back(entry.path());
  if (ec) return makeError(folder.string(), ": cannot list (", ec.message(), ")");
  if (tums.empty()) return makeError(folder.string(), ": no ground truth (*.tum)");
  for (const auto& tum : tums) {
    auto t = eval::readTum(tum);
    if (!t) return t.error();
    for (const auto& p : t->poses) truth.world_T_body[(p.t_ns + 500) / 1000] = p.world_T_body;
  }
  return truth;
}

Expected<RunTruth> truthFromSamples(const std::map<int64_t, core::SE3d>& poses,
                                    const std::map<int64_t, std::pair<int, int>>& floor_session) {
  if (poses.size() < 2)
    return makeError("ground truth: ", poses.size(), " GROUND_TRUTH samples (2 needed)");
  RunTruth truth;
  truth.world_T_body = poses;
  std::map<int, std::vector<double>> heights;
  std::set<int> sessions;
  for (const auto& [utime, fs] : floor_session) {
    auto it = poses.find(utime);
    if (fs.first >= 0 && it != poses.end())
      heights[fs.first].push_back(it->second.translation().z());
    if (fs.second >= 0) sessions.insert(fs.second);
  }
  for (auto& [floor, z] : heights) {
    std::nth_element(z.begin(), z.begin() + static_cast<long>(z.size() / 2), z.end());
    truth.floors[floor] = z[z.size() / 2];
  }
  truth.sessions = static_cast<int>(sessions.size());
  return truth;
}

Expected<RunTruth> readLogTruth(const std::vector<std::filesystem::path>& logs) {
  std::map<int64_t, core::SE3d> poses;
  std::map<int64_t, std::pair<int, int>> floor_session;
  for (const auto& file : logs) {
    auto opened = messages::LogReader::open(file);
    if (!opened) return opened.error();
    messages::LogReader& log = *opened;
    while (const messages::LogReader::Event* e = log.next()) {
      if (e->channel != channels::kGroundTruth) continue;
      auto p = decodeLoggedPose(*e);
      if (!p) return makeError(file.string(), ": ", p.error().message);
      poses[p->msg.utime] = p->world_T_body;
      floor_session[p->msg.utime] = {p->msg.floor, p->msg.session};
    }
    if (Status s = log.status(); !s) return s.error();
  }
  auto truth = truthFromSamples(poses, floor_session);
  if (!truth)
    return makeError(logs.empty() ? std::string("no log") : logs.front().string(), ": ",
                     truth.error().message);
  return truth;
}

namespace {

// The map's nodes whose keyframes the truth covers: their true and estimated poses.
struct NodesWithTruth {
  std::vector<core::SE3d> gt, est;
  std::vector<const EvalNode*> nodes;
};

// Floors: the map's floor table against the true heights, node labels right and right up to
// a relabelling (each label to the true floor most of its nodes are on).
void evaluateFloors(const EvalMap& map, const RunTruth& truth, MapEvaluation* e) {
  e->floors = static_cast<int>(map.floors.size());
  for (const auto& [index, height] : map.floors) {
    auto it = truth.floors.find(index);
    if (it != truth.floors.end() && std::abs(it->second - height) <= 0.25) ++e->floors_right;
  }
  std::map<int, std::map<int, int64_t>> label_votes;
  for (const EvalNode& n : map.nodes) {
    core::SE3d t;
    if (!truth.at(n.keyframe_utime, &t)) continue;
    if (truth.floorAt(t.translation().z()) == n.floor) ++e->nodes_floor_right;
    ++label_votes[n.floor][truth.floorAt(t.translation().z())];
  }
  for (const auto& [label, votes] : label_votes) {
    int64_t best = 0;
    for (const auto& [floor, count] : votes) best = std::max(best, count);
    e->nodes_floor_consistent += best;
  }
}

// Loop edges off the truth by more than 0.5 m or 5 degrees, one line each.
void evaluateLoops(const EvalMap& map, const std::map<int64_t, core::SE3d>& node_truth,
                   MapEvaluation* e) {
  for (const EvalLoop& l : map.loops) {
    auto a = node_truth.find(l.from), b = node_truth.find(l.to);
    if (a == node_truth.end() || b == node_truth.end()) continue;
    ++e->loops_with_truth;
    const core::SE3d err = (a->second.inverse() * b->second).inverse() * l.from_T_to;
    const double off_m = err.translation().norm(),
                 off_deg = core::rotationAngle(err.so3()) * 180.0 / M_PI;
    if (off_m > 0.5 || off_deg > 5.0) {
      ++e->false_loops;
      std::ostringstream line;
      line << l.from << "-" << l.to << ": " << off_m << " m, " << off_deg << " deg off the truth";
      e->false_loop_lines.push_back(line.str());
    }
  }
}

// Node ATE (3 nodes with truth at least for the alignment; else NaN, printed "n/a": a camera
// that turned in place) and the worst nodes after the same alignment, to find where a map
// went wrong.
Status evaluateNodeAte(const NodesWithTruth& n, MapEvaluation* e) {
  e->ate_rmse_m = e->ate_median_m = e->ate_max_m = std::numeric_limits<double>::quiet_NaN();
  if (n.gt.size() < 3) return Ok{};
  auto ate = alignedAte(n.gt, n.est);
  if (!ate) return makeError("map evaluation: node ATE: ", ate.error().message);
  e->ate_rmse_m = ate->rmse;
  e->ate_median_m = ate->median;
  e->ate_max_m = ate->max;
  auto aligned = eval::alignTrajectories(n.gt, n.est, eval::AlignmentMode::kSE3);
  if (!aligned) return Ok{};
  std::vector<std::pair<double, const EvalNode*>> off;
  for (size_t i = 0; i < n.gt.size(); ++i)
    off.emplace_back(((aligned->gt_S_est * n.est[i]).translation() - n.gt[i].translation()).norm(),
                     n.nodes[i]);
  std::sort(off.begin(), off.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  for (size_t i = 0; i < std::min<size_t>(5, off.size()); ++i) {
    std::ostringstream line;
    line << off[i].second->id << " (session " << off[i].second->session << ", utime "
         << off[i].second->keyframe_utime << "): " << off[i].first << " m";
    e->worst_node_lines.push_back(line.str());
  }
  return Ok{};
}

// ATE of the live poses (POSE) with truth, 3 at least.
Status evaluatePoseAte(const RunTruth& truth,
                       const std::vector<std::pair<int64_t, core::SE3d>>& poses, MapEvaluation* e) {
  std::vector<core::SE3d> gt, est;
  for (const auto& [utime, pose] : poses) {
    core::SE3d t;
    if (!truth.at(utime, &t)) continue;
    gt.push_back(t);
    est.push_back(pose);
  }
  e->poses = static_cast<int64_t>(gt.size());
  if (gt.size() < 3) return Ok{};
  auto pose_ate = alignedAte(gt, est);
  if (!pose_ate) return makeError("map evaluation: POSE ATE: ", pose_ate.error().message);
  e->pose_ate_rmse_m = pose_ate->rmse;
  e->pose_ate_median_m = pose_ate->median;
  return Ok{};
}

}  // namespace

Expected<MapEvaluation> evaluateMap(const EvalMap& map, const RunTruth& truth,
                                    const std::vector<std::pair<int64_t, core::SE3d>>& poses) {
  MapEvaluation e;
  e.nodes = static_cast<int64_t>(map.nodes.size());
  e.edges = map.edges;
  e.loop_edges = map.loop_edges;
  e.sessions_truth = truth.sessions;
  std::set<int> sessions;
  NodesWithTruth with_truth;
  std::map<int64_t, core::SE3d> node_truth;
  for (const EvalNode& n : map.nodes) {
    sessions.insert(n.session);
    core::SE3d t;
    if (!truth.at(n.keyframe_utime, &t)) continue;
    with_truth.gt.push_back(t);
    with_truth.est.push_back(n.world_T_body);
    with_truth.nodes.push_back(&n);
    node_truth[n.id] = t;
  }
  e.sessions = static_cast<int>(sessions.size());
  e.nodes_with_truth = static_cast<int64_t>(with_truth.gt.size());
  evaluateFloors(map, truth, &e);
  evaluateLoops(map, node_truth, &e);
  if (Status s = evaluateNodeAte(with_truth, &e); !s) return s.error();
  if (Status s = evaluatePoseAte(truth, poses, &e); !s) return s.error();
  return e;
}

namespace {
// A number for JSON: null for NaN (node ATE of a map with fewer than 3 nodes).
std::string jsonNumber(double v) {
  if (std::isnan(v)) return "null";
  std::ostringstream s;
  s << v;
  return s.str();
}
}  // namespace

std::string MapEvaluation::text() const {
  std::ostringstream s;
  s << "nodes " << nodes << " (" << nodes_with_truth << " with ground truth)\n"
    << "edges " << edges << " (" << loop_edges << " holding loop closures)\n"
    << "floors " << floors << " (" << floors_right << " at the building's height)\n"
    << "nodes_on_true_floor " << nodes_floor_right << "\n"
    << "nodes_on_consistent_floor " << nodes_floor_consistent << "\n"
    << "loop_edges_false " << false_loops << " (of " << loops_with_truth << " with truth)\n";
  for (const std::string& line : false_loop_lines) s << "false_loop_edge " << line << "\n";
  s << "sessions " << sessions << " (run: " << sessions_truth << ")\n";
  if (std::isnan(ate_rmse_m))
    s << "node_ate_rmse_m n/a (" << nodes_with_truth << " nodes with ground truth, 3 needed)\n";
  else
    s << "node_ate_rmse_m " << ate_rmse_m << "\nnode_ate_median_m " << ate_median_m
      << "\nnode_ate_max_m " << ate_max_m << "\n";
  for (const std::string& line : worst_node_lines) s << "node_ate_worst " << line << "\n";
  if (poses > 0)
    s << "poses " << poses << "\npose_ate_rmse_m " << pose_ate_rmse_m << "\npose_ate_median_m "
      << pose_ate_median_m << "\n";
  return s.str();
}

std::string MapEvaluation::json() const {
  std::ostringstream s;
  s << "{\"nodes\": " << nodes << ", \"nodes_with_truth\": " << nodes_with_truth
    << ", \"edges\": " << edges << ", \"loop_edges\": " << loop_edges << ", \"floors\": " << floors
    << ", \"floors_right\": " << floors_right << ", \"nodes_on_true_floor\": " << nodes_floor_right
    << ", \"nodes_on_consistent_floor\": " << nodes_floor_consistent
    << ", \"loop_edges_false\": " << false_loops << ", \"sessions\": " << sessions
    << ", \"sessions_truth\": " << sessions_truth
    << ", \"node_ate_rmse_m\": " << jsonNumber(ate_rmse_m)
    << ", \"node_ate_median_m\": " << jsonNumber(ate_median_m)
    << ", \"node_ate_max_m\": " << jsonNumber(ate_max_m) << ", \"poses\": " << poses
    << ", \"pose_ate_rmse_m\": " << pose_ate_rmse_m
    << ", \"pose_ate_median_m\": " << pose_ate_median_m << "}\n";
  return s.str();
}

}  // namespace evermap::mapper
