#pragma once
// loopclose-proc's logic, without LCM (DESIGN.md sections 1 and 5; paper IV-C, IV-D):
//  - keeps a bounded cache of the most recent keyframes (KEYFRAME);
//  - when the mapper announces a node (NODE_ADDED), stores the keyframe that describes it and
//    adds the node to the place database (bag-of-words vector, floor, time), persisting both
//    in the map store when one is given;
//  - answers registration requests (REGISTER_REQUEST): the query keyframe against one given
//    node (MODE_NODE), or against the best places of an appearance search on the requested
//    floor (MODE_GLOBAL, candidates tried in score order until one registers);
//  - a keyframe it needs (named by a NODE_ADDED or a request) and does not hold is asked of
//    vo-proc again (KEYFRAME_REQUEST, keyframe_requests.h), which answers in parts
//    (KEYFRAME_PART): the node, or the request up to max_request_age_us, waits for it while it
//    is asked for;
//  - at most `max_rate_hz` answers per second of data time, newest request first; a request
//    that waited `max_request_age_us` of data time since it arrived, or pushed out of the
//    bounded queue, is answered STATUS_STALE and counted. Every failure is an answer with a status
//    and a reason: the process never dies on input.
// Time is data time: the newest utime of any message received (never the wall clock).
// Threading: one thread; the caller serialises all calls.

#include <cstdint>
#include <deque>
#include <list>
#include <memory>
#include <optional>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include <evermap/map_graph_t.hpp>
#include <evermap/node_added_t.hpp>
#include <evermap/register_request_t.hpp>
#include <evermap/register_result_t.hpp>

#include "core/bow/place_database.h"
#include "core/bow/place_store.h"
#include "core/bow/vocabulary.h"
#include "core/common/expected.h"
#include "core/common/option_fields.h"
#include "loopclose-proc/keyframe.h"
#include "loopclose-proc/keyframe_requests.h"
#include "loopclose-proc/registration.h"

namespace evermap::loopclose {

struct LoopCloserOptions {
  // Answers per second of data time (the paper's loop closure runs at 2 Hz).
  double max_rate_hz = 2.0;
  // A request that waited this long (data time since it arrived) is stale, microseconds. Since
  // its arrival, not since its stamp: a request sent on the first of a burst of frames (VO's
  // start-up hold releases seconds of them at once) arrives seconds behind the newest data,
  // and answering it is as useful as it will ever be.
  int64_t max_request_age_us = 2'000'000;
  // A request for a keyframe not received yet waits this long (data time since it arrived)
  // for it, µs: vo-proc sends KEYFRAME right after the frame's VO_DELTA, but the mapper's
  // request on that VO_DELTA is small and a keyframe is tens of fragments, so the request
  // often comes first.
  int64_t keyframe_wait_us = 500'000;
  // Requests waiting at most; beyond, the oldest is answered stale.
  size_t max_pending_requests = 8;
  // Recent keyframes kept in memory for NODE_ADDED and queries.
  size_t recent_keyframes = 64;
  // Node keyframes kept decoded in memory when a map store holds the rest (with no store every
  // node keyframe stays in memory, up to max_places).
  size_t node_keyframe_cache = 256;
  // Places (map nodes) held at most: a NODE_ADDED beyond is refused and counted. What bounds
  // the map's memory by design (each place holds its bag-of-words vector, and without a store
  // its keyframe): 20,000 is 7x the paper-scale map (2,728 nodes on 10 floors).
  size_t max_places = 20000;
  // NODE_ADDED waiting for their keyframe at most; beyond, a new one is refused and counted.
  // The mapper makes a node or two per second and a keyframe is late by a fraction of one.
  size_t max_waiting_nodes = 32;
  // Plausibility of NODE_ADDED content: a node's floor label is in [-1, max_floor] (the
  // mapper labels floors 0, 1, ... in the order it finds them, -1 after a ride to a height
  // it could not label; the tallest building has 163 floors).
  int32_t max_floor = 999;
  // Appearance search: candidates tried, lowest score considered, and how recent a place may
  // be (places whose keyframe is within this of the query are not loop closures), µs.
  int global_candidates = 3;
  double min_candidate_score = 0.0;
  int64_t exclude_recent_us = 10'000'000;
  // Keyframes missed on a lossy link, asked of vo-proc again.
  KeyframeRequestOptions recovery;

  Status validate() const;
  void declareOptions(OptionList& o) {
    o.add("max_rate_hz", &max_rate_hz, "Hz", "answers per second of data time").positive();
    o.add("max_request_age_us", &max_request_age_us, "us",
          "a request that waited this long since it arrived is stale")
        .positive();
    o.add("keyframe_wait_us", &keyframe_wait_us, "us", "a request waits this long for its keyframe")
        .nonNegative();
    o.add("max_pending_requests", &max_pending_requests, "", "requests waiting at most").min(1);
    o.add("recent_keyframes", &recent_keyframes, "", "recent keyframes kept in memory").min(1);
    o.add("node_keyframe_cache", &node_keyframe_cache, "",
          "node keyframes kept decoded beside a map store")
        .min(1);
    o.add("max_places", &max_places, "", "places held at most; beyond, NODE_ADDED is refused")
        .min(1);
    o.add("max_waiting_nodes", &max_waiting_nodes, "", "NODE_ADDED waiting for a keyframe at most")
        .min(1);
    o.add("max_floor", &max_floor, "", "highest floor label a NODE_ADDED may carry").min(0);
    o.add("global_candidates", &global_candidates, "", "appearance candidates tried").min(1);
    o.add("min_candidate_score", &min_candidate_score, "", "lowest appearance score considered")
        .any();
    o.add("exclude_recent_us", &exclude_recent_us, "us",
          "places this recent before the query are no loop closures (not applied with a "
          "read-only store: localization)")
        .nonNegative();
    o.nest("recovery.", &recovery);
  }
};

struct LoopCloserStats {
  int64_t keyframes = 0;
  int64_t keyframes_rejected = 0;  // failed validation
  int64_t nodes = 0;
  int64_t nodes_rejected = 0;       // unknown keyframe, duplicate id, store failure, and:
  int64_t nodes_implausible = 0;    // ... content no mapper sends (ids, floor, stamps)
  int64_t nodes_over_capacity = 0;  // ... max_places or max_waiting_nodes reached
  int64_t nodes_waited = 0;         // came before their keyframe and waited for it
  int64_t nodes_caught_up = 0;      // taken from MAP_GRAPH, their NODE_ADDED never seen
  int64_t requests = 0;
  int64_t answered = 0;  // all answers, stale ones included
  int64_t stale = 0;
  int64_t ok = 0;
  int64_t failed = 0;  // answered with a failure status other than stale
  int64_t store_errors = 0;
  std::string text() const;  // one line
};

class LoopCloser {
 public:
  // `vocabulary` and `registration` must outlive the LoopCloser. With a `store`, the nodes it
  // holds are loaded (the place database is rebuilt from it) and new ones are written to it.
  static Expected<std::unique_ptr<LoopCloser>> create(const bow::Vocabulary& vocabulary,
                                                      FrameRegistration& registration,
                                                      const LoopCloserOptions& options,
                                                      std::optional<bow::PlaceStore> store);

  // KEYFRAME: validated and cached. An error names the keyframe (it is dropped and counted).
  Status addKeyframe(const evermap::keyframe_t& msg);
  // KEYFRAME_PART: a part of a keyframe asked for again; the keyframe it completes is taken as
  // a KEYFRAME. Parts of keyframes not asked for are ignored (counted in recoveryStats()).
  Status addKeyframePart(const evermap::keyframe_part_t& msg);
  // NODE_ADDED: the node's keyframe must be among the recent ones (or already stored). One
  // that came before its keyframe (the mapper's first node is made on the frame's VO_DELTA)
  // waits for it up to keyframe_wait_us of data time, or while the keyframe is asked for
  // again (recovery), and is added when it comes. Refused
  // (counted, the state left as it was): content no mapper sends (implausibleNode), a map of
  // max_places places, max_waiting_nodes nodes already waiting.
  Status addNode(const evermap::node_added_t& msg);
  // MAP_GRAPH: a node of the mapper's map never announced here (its NODE_ADDED lost on the
  // link, or sent while loopclose-proc was down) is added as if announced now, its keyframe
  // asked for again if missing. Each node is caught up once at most (a refusal is final).
  // Returns the nodes taken up (added or waiting for their keyframe).
  int catchUpNodes(const evermap::map_graph_t& graph);
  // The waiting nodes whose keyframe did not come in time, or that failed when it came
  // (rejected, counted in nodes_rejected): one line each, naming the node. Taken once.
  std::vector<std::string> takeNodeErrors();
  // REGISTER_REQUEST: queued; answered by poll().
  void submit(const evermap::register_request_t& request);
  // Data time from a stream that asks nothing (VO_DELTA, 20-30 Hz): answers fall due, and
  // requests go stale, between the keyframes and requests that otherwise set the clock.
  void advanceClock(int64_t utime);
  // KEYFRAME_REQUEST: the asks for missed keyframes due now. Nodes that waited for a keyframe
  // given up are rejected (takeNodeErrors()).
  std::vector<evermap::keyframe_request_t> takeKeyframeRequests();
  // The answers due now: stale requests, and at most one answer per 1/max_rate_hz of data time
  // (the newest pending request).
  std::vector<evermap::register_result_t> poll();
  // Answers one request immediately, ignoring rate and queue (tests, offline runs).
  evermap::register_result_t answer(const evermap::register_request_t& request);

  int64_t now() const { return now_utime_; }
  size_t numNodes() const { return places_.size(); }
  size_t pending() const { return pending_.size(); }
  const LoopCloserStats& stats() const { return stats_; }
  const KeyframeRequestStats& recoveryStats() const { return requests_.stats(); }

 private:
  struct Node {
    int32_t floor = 0;
    int64_t keyframe_utime = 0;
  };
  LoopCloser(const bow::Vocabulary& vocabulary, FrameRegistration& registration,
             const LoopCloserOptions& options, std::optional<bow::PlaceStore> store);
  // "" when `msg` could come from a mapper, else why not.
  std::string implausibleNode(const evermap::node_added_t& msg) const;
  const Keyframe* recentKeyframe(int64_t utime) const;
  // A recent keyframe, else the store's (the newest received of that utime); null if neither.
  std::shared_ptr<const Keyframe> keyframeForNode(int64_t utime) const;
  std::optional<int64_t> nodeOfKeyframe(int64_t utime) const;  // the node it describes, if any
  bool knowsKeyframe(int64_t utime) const;                     // a recent one, or a node's
  // A request waiting, with the data time it arrived at (its age counts from there).
  struct Pending {
    evermap::register_request_t request;
    int64_t arrived_utime = 0;
  };
  // Whether a request still waits for its query keyframe (in flight, or asked for again), or
  // for the keyframe of its MODE_NODE target (asked for again).
  bool awaitsKeyframe(const Pending& pending) const;
  // The keyframe of a node: memory, else the store (then cached). Null with a reason.
  std::shared_ptr<const Keyframe> nodeKeyframe(int64_t node_id, std::string* why);
  evermap::register_result_t failure(const evermap::register_request_t& request, int8_t status,
                                     std::string reason);
  evermap::register_result_t registerAgainst(const evermap::register_request_t& request,
                                             const Keyframe& query, int64_t node_id, double score,
                                             std::string* why);

  const bow::Vocabulary& vocabulary_;
  FrameRegistration& registration_;
  LoopCloserOptions options_;
  std::optional<bow::PlaceStore> store_;
  // A read-only store (localization): it holds only the stored map's places, none of the
  // stream's own, so their times neither start the clock nor are excluded as recent.
  bool stored_map_only_ = false;
  bow::PlaceDatabase places_;
  std::unordered_map<int64_t, Node> nodes_;
  std::deque<std::shared_ptr<const Keyframe>> recent_;  // oldest first
  // Node keyframes in memory: all of them without a store, else an LRU of bounded size.
  struct Cached {
    std::shared_ptr<const Keyframe> keyframe;
    std::list<int64_t>::iterator lru_position;
  };
  std::unordered_map<int64_t, Cached> node_keyframes_;
  std::list<int64_t> lru_;                           // node ids, most recently used first
  std::vector<evermap::register_result_t> ready_;    // stale answers made by submit()
  std::deque<Pending> pending_;                      // arrival order
  std::deque<evermap::node_added_t> waiting_nodes_;  // NODE_ADDED before its KEYFRAME
  std::vector<std::string> node_errors_;
  KeyframeRequests requests_;
  std::unordered_set<int64_t> caught_up_;  // node ids tried from MAP_GRAPH
  int64_t now_utime_ = 0;
  std::optional<int64_t> last_answer_utime_;
  LoopCloserStats stats_;
};

}  // namespace evermap::loopclose
