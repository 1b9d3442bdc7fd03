#include "loopclose-proc/loop_closer.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <utility>

#include "core/messages/pose_fields.h"

namespace evermap::loopclose {

using evermap::register_request_t;
using evermap::register_result_t;

Status LoopCloserOptions::validate() const {
  if (!(max_rate_hz > 0.0) || !std::isfinite(max_rate_hz)) {
    return makeError("max_rate_hz must be finite and > 0");
  }
  if (max_request_age_us <= 0) return makeError("max_request_age_us must be > 0");
  if (keyframe_wait_us < 0) return makeError("keyframe_wait_us must be >= 0");
  if (max_pending_requests < 1) return makeError("max_pending_requests must be >= 1");
  if (recent_keyframes < 1) return makeError("recent_keyframes must be >= 1");
  if (node_keyframe_cache < 1) return makeError("node_keyframe_cache must be >= 1");
  if (max_places < 1) return makeError("max_places must be >= 1");
  if (max_waiting_nodes < 1) return makeError("max_waiting_nodes must be >= 1");
  if (max_floor < 0) return makeError("max_floor must be >= 0");
  if (global_candidates < 1) return makeError("global_candidates must be >= 1");
  if (!std::isfinite(min_candidate_score)) return makeError("min_candidate_score must be finite");
  if (exclude_recent_us < 0) return makeError("exclude_recent_us must be >= 0");
  if (Status s = recovery.validate(); !s) return makeError("recovery.", s.error().message);
  return Ok{};
}

std::string LoopCloserStats::text() const {
  char line[400];
  std::snprintf(line, sizeof(line),
                "keyframes %lld (%lld rejected), nodes %lld (%lld rejected: %lld implausible, %lld "
                "over capacity; "
                "%lld waited for their keyframe, %lld caught up from MAP_GRAPH), requests %lld, "
                "answered %lld: ok %lld, failed %lld, stale %lld; store errors %lld",
                static_cast<long long>(keyframes), static_cast<long long>(keyframes_rejected),
                static_cast<long long>(nodes), static_cast<long long>(nodes_rejected),
                static_cast<long long>(nodes_implausible),
                static_cast<long long>(nodes_over_capacity), static_cast<long long>(nodes_waited),
                static_cast<long long>(nodes_caught_up), static_cast<long long>(requests),
                static_cast<long long>(answered), static_cast<long long>(ok),
                static_cast<long long>(failed), static_cast<long long>(stale),
                static_cast<long long>(store_errors));
  return line;
}

LoopCloser::LoopCloser(const bow::Vocabulary& vocabulary, FrameRegistration& registration,
                       const LoopCloserOptions& options, std::optional<bow::PlaceStore> store)
    : vocabulary_(vocabulary),
      registration_(registration),
      options_(options),
      store_(std::move(store)),
      stored_map_only_(store_ && store_->readOnly()),
      places_(vocabulary.numWords(), vocabulary.fingerprint()),
      requests_(options.recovery) {}

Expected<std::unique_ptr<LoopCloser>> LoopCloser::create(const bow::Vocabulary& vocabulary,
                                                         FrameRegistration& registration,
                                                         const LoopCloserOptions& options,
                                                         std::optional<bow::PlaceStore> store) {
  if (Status s = options.validate(); !s) return makeError("loopclose options: ", s.error().message);
  std::unique_ptr<LoopCloser> lc(
      new LoopCloser(vocabulary, registration, options, std::move(store)));
  if (lc->store_) {
    // The store was opened with this vocabulary's fingerprint (PlaceStore::open checks it).
    auto db = lc->store_->loadDatabase();
    if (!db) return db.error();
    // A map continued (mapping) goes on from its newest place's time; a stored map's times
    // say nothing of the stream's clock (an old log localized in a newer map would be answered
    // from the future).
    for (const bow::Place& p : db->places()) {
      lc->nodes_[p.id] = Node{p.floor, p.utime};
      if (!lc->stored_map_only_) lc->now_utime_ = std::max(lc->now_utime_, p.utime);
    }
    lc->places_ = std::move(*db);
    lc->stats_.nodes = static_cast<int64_t>(lc->nodes_.size());
  }
  return lc;
}

void LoopCloser::advanceClock(int64_t utime) {
  now_utime_ = std::max(now_utime_, utime);
  // Any waiting node whose time is up, not only the oldest to arrive: one stamped ahead of the
  // others would otherwise hold every later one behind it.
  for (auto it = waiting_nodes_.begin(); it != waiting_nodes_.end();) {
    if (now_utime_ - it->utime < options_.keyframe_wait_us ||
        requests_.awaits(it->keyframe_utime)) {
      ++it;
      continue;
    }
    ++stats_.nodes_rejected;
    char line[200];
    std::snprintf(line, sizeof(line), "node %lld: its keyframe %lld did not come within %.1f s",
                  static_cast<long long>(it->node_id), static_cast<long long>(it->keyframe_utime),
                  1e-6 * static_cast<double>(options_.keyframe_wait_us));
    node_errors_.emplace_back(line);
    it = waiting_nodes_.erase(it);
  }
}

std::vector<std::string> LoopCloser::takeNodeErrors() { return std::exchange(node_errors_, {}); }

std::vector<evermap::keyframe_request_t> LoopCloser::takeKeyframeRequests() {
  std::vector<int64_t> given_up;
  std::vector<evermap::keyframe_request_t> asks = requests_.due(now_utime_, &given_up);
  for (const int64_t keyframe_utime : given_up) {
    for (auto it = waiting_nodes_.begin(); it != waiting_nodes_.end();) {
      if (it->keyframe_utime != keyframe_utime) {
        ++it;
        continue;
      }
      ++stats_.nodes_rejected;
      char line[200];
      std::snprintf(line, sizeof(line), "node %lld: its keyframe %lld did not come, asked %d times",
                    static_cast<long long>(it->node_id), static_cast<long long>(keyframe_utime),
                    options_.recovery.max_attempts);
      node_errors_.emplace_back(line);
      it = waiting_nodes_.erase(it);
    }
  }
  return asks;
}

Status LoopCloser::addKeyframePart(const evermap::keyframe_part_t& msg) {
  Expected<std::optional<evermap::keyframe_t>> keyframe = requests_.addPart(msg);
  if (!keyframe) return keyframe.error();
  if (!*keyframe) return Ok{};
  return addKeyframe(**keyframe);
}

Status LoopCloser::addKeyframe(const evermap::keyframe_t& msg) {
  auto k = fromMsg(msg);
  if (!k) {
    ++stats_.keyframes_rejected;
    return k.error();
  }
  advanceClock(msg.utime);
  ++stats_.keyframes;
  requests_.received(msg.utime);
  auto shared = std::make_shared<const Keyframe>(std::move(*k));
  auto same = std::find_if(recent_.begin(), recent_.end(),
                           [&](const auto& r) { return r->utime() == shared->utime(); });
  if (same != recent_.end()) {
    *same = shared;  // a repeated keyframe replaces the old one
  } else {
    recent_.push_back(shared);
  }
  while (recent_.size() > options_.recent_keyframes) recent_.pop_front();
  // Nodes that came before this keyframe, taken out first (addNode may queue again). Their
  // errors are theirs, not the keyframe's (it is kept): reported by takeNodeErrors().
  std::vector<evermap::node_added_t> released;
  for (auto it = waiting_nodes_.begin(); it != waiting_nodes_.end();) {
    if (it->keyframe_utime == msg.utime) {
      released.push_back(*it);
      it = waiting_nodes_.erase(it);
    } else {
      ++it;
    }
  }
  for (const evermap::node_added_t& n : released) {
    if (Status s = addNode(n); !s) node_errors_.push_back(s.error().message);
  }
  return Ok{};
}

const Keyframe* LoopCloser::recentKeyframe(int64_t utime) const {
  for (auto it = recent_.rbegin(); it != recent_.rend(); ++it) {
    if ((*it)->utime() == utime) return it->get();
  }
  return nullptr;
}

std::optional<int64_t> LoopCloser::nodeOfKeyframe(int64_t utime) const {
  for (const auto& [id, node] : nodes_) {
    if (node.keyframe_utime == utime) return id;
  }
  return std::nullopt;
}

bool LoopCloser::knowsKeyframe(int64_t utime) const {
  return recentKeyframe(utime) != nullptr || nodeOfKeyframe(utime).has_value();
}

int LoopCloser::catchUpNodes(const evermap::map_graph_t& graph) {
  int taken = 0;
  for (const evermap::map_node_t& n : graph.nodes) {
    if (nodes_.count(n.node_id) || caught_up_.count(n.node_id)) continue;
    if (std::any_of(waiting_nodes_.begin(), waiting_nodes_.end(),
                    [&](const auto& w) { return w.node_id == n.node_id; }))
      continue;
    caught_up_.insert(n.node_id);
    evermap::node_added_t msg{};
    msg.utime = graph.utime;
    msg.node_id = n.node_id;
    msg.keyframe_utime = n.keyframe_utime;
    msg.floor = n.floor;
    msg.session = n.session;
    if (Status s = addNode(msg); !s) {
      node_errors_.push_back("from MAP_GRAPH: " + s.error().message);
      continue;
    }
    ++stats_.nodes_caught_up;
    ++taken;
  }
  return taken;
}

bool LoopCloser::awaitsKeyframe(const Pending& pending) const {
  const register_request_t& request = pending.request;
  if (!knowsKeyframe(request.keyframe_utime)) {
    return now_utime_ - pending.arrived_utime < options_.keyframe_wait_us ||
           requests_.awaits(request.keyframe_utime);
  }
  // MODE_NODE against a node that waits for its keyframe (asked for again): answered "unknown
  // node" now, the registration would be lost.
  if (request.mode != register_request_t::MODE_NODE || nodes_.count(request.target_node_id))
    return false;
  return std::any_of(waiting_nodes_.begin(), waiting_nodes_.end(), [&](const auto& n) {
    return n.node_id == request.target_node_id && requests_.awaits(n.keyframe_utime);
  });
}

std::string LoopCloser::implausibleNode(const evermap::node_added_t& msg) const {
  std::ostringstream why;
  if (msg.node_id < 0) {
    why << "node id " << msg.node_id << " is negative";
  } else if (msg.session < 0) {
    why << "session " << msg.session << " is negative";
  } else if (msg.floor < -1 || msg.floor > options_.max_floor) {
    why << "floor " << msg.floor << " is outside [-1, max_floor " << options_.max_floor << "]";
  } else if (msg.keyframe_utime < 0 || msg.keyframe_utime > msg.utime) {
    // The mapper makes a node on its keyframe's frame, never before it.
    why << "keyframe " << msg.keyframe_utime << " is negative or after the node's stamp "
        << msg.utime;
  }
  return why.str();
}

std::shared_ptr<const Keyframe> LoopCloser::keyframeForNode(int64_t utime) const {
  std::shared_ptr<const Keyframe> keyframe;
  for (const auto& r : recent_) {
    if (r->utime() == utime) keyframe = r;
  }
  if (!keyframe && store_) {
    auto stored = store_->loadKeyframe(utime);
    if (stored && stored->has_value()) {
      auto k = fromMsg(**stored);
      if (k) keyframe = std::make_shared<const Keyframe>(std::move(*k));
    }
  }
  return keyframe;
}

Status LoopCloser::addNode(const evermap::node_added_t& msg) {
  if (const std::string why = implausibleNode(msg); !why.empty()) {
    ++stats_.nodes_rejected;
    ++stats_.nodes_implausible;
    return makeError("node ", msg.node_id, ": ", why);
  }
  if (places_.size() >= options_.max_places) {
    ++stats_.nodes_rejected;
    ++stats_.nodes_over_capacity;
    return makeError("node ", msg.node_id, ": the map holds max_places = ", options_.max_places,
                     " places");
  }
  advanceClock(msg.utime);
  if (nodes_.count(msg.node_id)) {
    ++stats_.nodes_rejected;
    return makeError("node ", msg.node_id, ": already known");
  }
  if (std::any_of(waiting_nodes_.begin(), waiting_nodes_.end(),
                  [&](const auto& n) { return n.node_id == msg.node_id; })) {
    ++stats_.nodes_rejected;
    return makeError("node ", msg.node_id, ": already waiting for its keyframe");
  }
  std::shared_ptr<const Keyframe> keyframe = keyframeForNode(msg.keyframe_utime);
  // In flight (the wait), or lost on the link and asked for again (the recovery).
  const bool in_flight = now_utime_ - msg.utime < options_.keyframe_wait_us;
  if (!keyframe && (in_flight || requests_.enabled())) {
    if (waiting_nodes_.size() >= options_.max_waiting_nodes) {
      ++stats_.nodes_rejected;
      ++stats_.nodes_over_capacity;
      return makeError("node ", msg.node_id, ": max_waiting_nodes = ", options_.max_waiting_nodes,
                       " nodes already wait for their keyframe");
    }
    if (!requests_.need(msg.keyframe_utime, now_utime_) && !in_flight) {
      ++stats_.nodes_rejected;
      return makeError("node ", msg.node_id, ": keyframe ", msg.keyframe_utime, " is missing and ",
                       requests_.open(), " keyframes are asked for already");
    }
    waiting_nodes_.push_back(msg);
    ++stats_.nodes_waited;
    return Ok{};
  }
  if (!keyframe) {
    ++stats_.nodes_rejected;
    return makeError("node ", msg.node_id, ": keyframe ", msg.keyframe_utime, " is not among the ",
                     recent_.size(), " recent keyframes");
  }
  bow::Place place{msg.node_id, msg.floor, msg.keyframe_utime,
                   vocabulary_.transform(keyframe->bowDescriptors())};
  Status persisted = Ok{};
  if (store_) {
    // The keyframe first: a place is never stored without the keyframe behind it.
    const evermap::keyframe_t k = toMsg(*keyframe);
    persisted = store_->saveKeyframes(std::span<const evermap::keyframe_t>(&k, 1));
    if (persisted) persisted = store_->savePlaces(std::span<const bow::Place>(&place, 1));
    if (!persisted) ++stats_.store_errors;
  }
  if (Status s = places_.insert(std::move(place)); !s) {
    ++stats_.nodes_rejected;
    return s;
  }
  nodes_[msg.node_id] = Node{msg.floor, msg.keyframe_utime};
  ++stats_.nodes;
  lru_.push_front(msg.node_id);
  node_keyframes_[msg.node_id] = Cached{keyframe, lru_.begin()};
  if (store_) {
    while (lru_.size() > options_.node_keyframe_cache) {
      node_keyframes_.erase(lru_.back());
      lru_.pop_back();
    }
  }
  if (!persisted) {
    return makeError("node ", msg.node_id,
                     ": kept in memory but not stored: ", persisted.error().message);
  }
  return Ok{};
}

std::shared_ptr<const Keyframe> LoopCloser::nodeKeyframe(int64_t node_id, std::string* why) {
  if (auto it = node_keyframes_.find(node_id); it != node_keyframes_.end()) {
    lru_.splice(lru_.begin(), lru_, it->second.lru_position);
    return it->second.keyframe;
  }
  const auto node = nodes_.find(node_id);
  if (node == nodes_.end()) {
    *why = "node " + std::to_string(node_id) + " is not in the map";
    return nullptr;
  }
  if (!store_) {
    *why = "node " + std::to_string(node_id) + " has no keyframe";
    return nullptr;
  }
  auto stored = store_->loadKeyframe(node->second.keyframe_utime);
  if (!stored || !stored->has_value()) {
    *why = "keyframe " + std::to_string(node->second.keyframe_utime) + " of node " +
           std::to_string(node_id) + " is not in the map store" +
           (stored ? std::string() : ": " + stored.error().message);
    ++stats_.store_errors;
    return nullptr;
  }
  auto k = fromMsg(**stored);
  if (!k) {
    *why = "stored " + k.error().message;
    ++stats_.store_errors;
    return nullptr;
  }
  auto shared = std::make_shared<const Keyframe>(std::move(*k));
  lru_.push_front(node_id);
  node_keyframes_[node_id] = Cached{shared, lru_.begin()};
  while (lru_.size() > options_.node_keyframe_cache) {
    node_keyframes_.erase(lru_.back());
    lru_.pop_back();
  }
  return shared;
}

void LoopCloser::submit(const register_request_t& request) {
  advanceClock(request.utime);
  ++stats_.requests;
  if (!knowsKeyframe(request.keyframe_utime)) requests_.need(request.keyframe_utime, now_utime_);
  pending_.push_back(Pending{request, now_utime_});
  while (pending_.size() > options_.max_pending_requests) {
    // The oldest by stamp goes: newest requests are served first.
    auto oldest = std::min_element(
        pending_.begin(), pending_.end(),
        [](const auto& a, const auto& b) { return a.request.utime < b.request.utime; });
    ready_.push_back(failure(oldest->request, register_result_t::STATUS_STALE,
                             "dropped: more than " + std::to_string(options_.max_pending_requests) +
                                 " requests waiting"));
    pending_.erase(oldest);
  }
}

std::vector<register_result_t> LoopCloser::poll() {
  std::vector<register_result_t> out = std::move(ready_);
  ready_.clear();
  for (auto it = pending_.begin(); it != pending_.end();) {
    if (now_utime_ - it->arrived_utime > options_.max_request_age_us) {
      char why[128];
      std::snprintf(why, sizeof(why), "stale: waited %.3f s of data time (limit %.3f s)",
                    1e-6 * static_cast<double>(now_utime_ - it->arrived_utime),
                    1e-6 * static_cast<double>(options_.max_request_age_us));
      out.push_back(failure(it->request, register_result_t::STATUS_STALE, why));
      it = pending_.erase(it);
    } else {
      ++it;
    }
  }
  const auto period_us = static_cast<int64_t>(std::llround(1e6 / options_.max_rate_hz));
  if (!pending_.empty() && (!last_answer_utime_ || now_utime_ - *last_answer_utime_ >= period_us)) {
    // Newest first; among equal stamps the one that arrived last. One whose keyframe may still
    // come (on its way, or asked for again) waits, and the slot goes to the next.
    auto newest = pending_.end();
    for (auto it = pending_.begin(); it != pending_.end(); ++it) {
      if (awaitsKeyframe(*it)) continue;
      if (newest == pending_.end() || it->request.utime >= newest->request.utime) newest = it;
    }
    if (newest == pending_.end()) return out;
    const register_request_t request = newest->request;
    pending_.erase(newest);
    out.push_back(answer(request));
    last_answer_utime_ = now_utime_;
  }
  return out;
}

register_result_t LoopCloser::failure(const register_request_t& request, int8_t status,
                                      std::string reason) {
  register_result_t r{};
  r.utime = now_utime_;
  r.request_id = request.request_id;
  r.keyframe_utime = request.keyframe_utime;
  r.status = status;
  r.node_id = request.mode == register_request_t::MODE_NODE ? request.target_node_id : -1;
  r.orientation[0] = 1.0;
  r.reason = std::move(reason);
  ++stats_.answered;
  if (status == register_result_t::STATUS_STALE) {
    ++stats_.stale;
  } else {
    ++stats_.failed;
  }
  return r;
}

register_result_t LoopCloser::registerAgainst(const register_request_t& request,
                                              const Keyframe& query, int64_t node_id, double score,
                                              std::string* why) {
  std::string missing;
  const std::shared_ptr<const Keyframe> target = nodeKeyframe(node_id, &missing);
  register_result_t r{};
  r.status = register_result_t::STATUS_TOO_FEW_INLIERS;
  if (!target) {
    r.status = register_result_t::STATUS_UNKNOWN_KEYFRAME;
    *why = missing;
    return r;
  }
  if (target->size() == 0) {
    *why = "keyframe " + std::to_string(target->utime()) + " of node " + std::to_string(node_id) +
           " has no features";
    return r;
  }
  const RegistrationOutcome o = registration_.registerFrames(*target, query);
  const Eigen::Vector4d q(o.target_T_query.so3().quaternion().coeffs());
  if (!o.ok) {
    *why = o.reason.empty() ? "registration failed" : o.reason;
    return r;
  }
  if (!o.target_T_query.translation().allFinite() || !q.allFinite() || !o.covariance.allFinite()) {
    *why = "registration returned a non-finite pose or covariance";
    return r;
  }
  r.utime = now_utime_;
  r.request_id = request.request_id;
  r.keyframe_utime = request.keyframe_utime;
  r.status = register_result_t::STATUS_OK;
  r.node_id = node_id;
  messages::putPose(o.target_T_query, r.translation, r.orientation);
  for (int i = 0; i < 6; ++i) {
    for (int j = 0; j < 6; ++j) r.covariance[6 * i + j] = o.covariance(i, j);
  }
  r.num_inliers = o.inliers;
  r.score = score;
  ++stats_.answered;
  ++stats_.ok;
  return r;
}

register_result_t LoopCloser::answer(const register_request_t& request) {
  if (request.mode != register_request_t::MODE_NODE &&
      request.mode != register_request_t::MODE_GLOBAL) {
    return failure(
        request, register_result_t::STATUS_MALFORMED,
        "mode " + std::to_string(request.mode) + " is neither MODE_NODE (0) nor MODE_GLOBAL (1)");
  }
  // The query: a recent keyframe, or the keyframe of a node (an old keyframe asked again).
  std::shared_ptr<const Keyframe> query_holder;
  const Keyframe* query = recentKeyframe(request.keyframe_utime);
  if (!query) {
    if (const std::optional<int64_t> id = nodeOfKeyframe(request.keyframe_utime)) {
      std::string ignored;
      query_holder = nodeKeyframe(*id, &ignored);
      query = query_holder.get();
    }
  }
  if (!query) {
    return failure(request, register_result_t::STATUS_UNKNOWN_KEYFRAME,
                   "keyframe " + std::to_string(request.keyframe_utime) + " is not among the " +
                       std::to_string(recent_.size()) + " recent keyframes nor a node's");
  }
  if (query->size() == 0) {
    return failure(request, register_result_t::STATUS_TOO_FEW_INLIERS,
                   "query keyframe " + std::to_string(query->utime()) + " has no features");
  }
  const bow::BowVector query_bow = vocabulary_.transform(query->bowDescriptors());

  if (request.mode == register_request_t::MODE_NODE) {
    const bow::Place* place = places_.find(request.target_node_id);
    if (!place) {
      return failure(request, register_result_t::STATUS_UNKNOWN_NODE,
                     "node " + std::to_string(request.target_node_id) + " is not in the map");
    }
    std::string why;
    register_result_t r = registerAgainst(request, *query, request.target_node_id,
                                          bow::l1Score(query_bow, place->bow), &why);
    if (r.status == register_result_t::STATUS_OK) return r;
    return failure(request, r.status, why);
  }

  bow::PlaceQuery q;
  if (request.floor >= 0) q.floor = request.floor;
  // A stored map's places are none of the query session's: none is excluded by time (a map
  // may be seconds older than the query, cut from one recording, or newer than an old log).
  const int64_t exclude_us = stored_map_only_ ? 0 : options_.exclude_recent_us;
  if (!stored_map_only_) q.newest_utime = query->utime() - exclude_us;
  q.top_k = options_.global_candidates;
  q.min_score = options_.min_candidate_score;
  auto candidates = places_.query(query_bow, q);
  if (!candidates || candidates->empty()) {
    char why[160];
    std::snprintf(why, sizeof(why),
                  "no place%s%s more than %.1f s older than the query shares words with it "
                  "(%zu places in the map)",
                  q.floor ? " on floor " : "", q.floor ? std::to_string(*q.floor).c_str() : "",
                  1e-6 * static_cast<double>(exclude_us), places_.size());
    return failure(request, register_result_t::STATUS_NO_CANDIDATE, why);
  }
  std::string reasons;
  for (const bow::PlaceMatch& m : *candidates) {
    std::string why;
    register_result_t r = registerAgainst(request, *query, m.id, m.score, &why);
    if (r.status == register_result_t::STATUS_OK) return r;
    char head[96];
    std::snprintf(head, sizeof(head), "%snode %lld (score %.3f): ", reasons.empty() ? "" : "; ",
                  static_cast<long long>(m.id), m.score);
    reasons += head + why;
  }
  return failure(request, register_result_t::STATUS_TOO_FEW_INLIERS,
                 std::to_string(candidates->size()) + " candidates failed: " + reasons);
}

}  // namespace evermap::loopclose
