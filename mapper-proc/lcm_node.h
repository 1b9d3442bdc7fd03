#pragma once
// The mapper on LCM (DESIGN.md section 1): subscribes to STEREO_CALIB (or RGBD_CALIB), VO_DELTA,
// WHEEL_ODOM, ATTITUDE, FLOOR and REGISTER_RESULT, feeds the Mapper, publishes its REGISTER_REQUEST
// and NODE_ADDED, POSE at every VO frame (and wheel increment while VO is down; not while a new
// session is still lost), MAP_GRAPH when the graph changed and MAPPER_STATS, and writes the map
// store after every update that changed the graph.
//
// Input goes through a messages::Inbox (core/messages/inbox.h): one decoding path, a bounded
// queue per subscription (large: the mapper must see every odometry message and every answer,
// and bounded: a flood must not take the memory; docs/lcm.md), the message time guard (one
// message stamped 2^62 must not become "now"), exceptions caught. A message that does not
// decode, that the guard or the mapper refuses (malformed, non-finite, out of order, an answer
// to no request) is dropped and counted; MAPPER_STATS and INPUT_STATS carry the counts.
//
// STEREO_CALIB is latched (calibration_latch.h): VO_DELTA is refused, counted, until the first
// valid one has arrived; wheel odometry tracks meanwhile. Sources repeat it every second.
//
// Publishing rates are in message time (the latest utime received), so a replay at any speed
// produces the same MAP_GRAPH sequence: MAP_GRAPH at most every graph_period_s and only after a
// change, MAPPER_STATS every stats_period_s. flush() publishes both at once (idle, exit).
// Threading: handlers run inside lcm.handle() on the caller's thread; none of this is shared.

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include <evermap/map_graph_t.hpp>
#include <evermap/mapper_stats_t.hpp>

#include "core/common/expected.h"
#include "core/messages/inbox.h"
#include "core/messages/outbox.h"
#include "mapper-proc/calibration_latch.h"
#include "mapper-proc/map_store.h"
#include "mapper-proc/mapper.h"

namespace evermap::mapper {

struct LcmNodeOptions {
  // MAP_GRAPH after a change, at most this often; seconds of message time.
  double graph_period_s = 1.0;
  // MAPPER_STATS this often; seconds of message time.
  double stats_period_s = 1.0;
  // The input boundary: queue capacity per subscription, time guard.
  messages::Inbox::Options input = defaultInput();

  static messages::Inbox::Options defaultInput() {
    messages::Inbox::Options o;
    o.process = "evermap-mapper-proc";
    o.queue_capacity = 10000;  // ~50 s of input at 200 msg/s; a 20x replay's 2.5 s
    return o;
  }
  Status validate() const;
};

// Wall-clock time per component since the previous MAPPER_STATS, seconds (measurement only).
struct ComponentTimes {
  double tracking_s = 0.0;
  double registration_s = 0.0;
  double partition_s = 0.0;
  double solver_s = 0.0;
  double store_s = 0.0;
  double publish_s = 0.0;
};

struct LcmNodeCounts {
  std::map<std::string, int64_t> received;  // per channel, decodable or not
  int64_t undecodable = 0;
  int64_t time_refused = 0;          // stamped far from the stream's clock (Inbox time guard)
  int64_t failed = 0;                // a handler threw (caught at the boundary)
  int64_t refused = 0;               // decoded, but the mapper dropped it (its own count)
  int64_t no_calibration = 0;        // VO_DELTA before the first valid STEREO_CALIB
  int64_t calibrations_refused = 0;  // STEREO_CALIB that decoded but did not validate
  int64_t camera_changes = 0;        // distinct valid calibrations applied
  int64_t poses = 0;                 // POSE published
  int64_t graphs = 0;                // MAP_GRAPH published
  int64_t stats = 0;                 // MAPPER_STATS published
  int64_t store_transactions = 0;
  int64_t tracking_transactions = 0;  // the tracking state alone, between store transactions
  int64_t tracking_failures = 0;
  int64_t dropped() const {
    return undecodable + time_refused + failed + refused + no_calibration + calibrations_refused;
  }
};

// MAP_GRAPH of the mapper's current state: every node (but a quarantined session's, mapper.h) with
// its estimate, one edge per node pair (the merged factor; num_measurements = accepted constraints
// of the pair), the floors.
map_graph_t graphMessage(const Mapper& mapper, int64_t utime);

class LcmNode {
 public:
  // `lcm`, `mapper` and `store` (may be null: no store) must outlive the node.
  LcmNode(lcm::LCM& lcm, Mapper& mapper, const LcmNodeOptions& options, MapStore* store = nullptr);

  // Publishes MAP_GRAPH (if the graph changed since the last one) and MAPPER_STATS now.
  void flush();
  LcmNodeCounts counts() const;
  const messages::Inbox& inbox() const { return inbox_; }
  const CalibrationLatch& calibration() const { return calibration_; }
  // The first store error, if any (the node stops writing after it).
  const Status& storeStatus() const { return store_status_; }
  // The newest message time received, µs (-1 before the first message).
  int64_t lastUtime() const { return last_utime_; }
  // A one-line-per-figure summary for the end of a run.
  std::string summary() const;

 private:
  template <typename Msg>
  Status on(const Msg& msg);
  Status onCalibration(const void* data, int64_t size);
  void afterMessage(int64_t utime, bool publish_pose);
  void publishGraph();
  void publishStats();
  void save();

  lcm::LCM& lcm_;
  messages::Outbox out_;  // every publish, sealed with input.signer
  Mapper& m_;
  LcmNodeOptions o_;
  MapStore* store_;
  Status store_status_ = Ok{};
  LcmNodeCounts counts_;
  CalibrationLatch calibration_;
  int64_t last_utime_ = -1;
  int64_t last_graph_utime_ = -1;
  int64_t last_stats_utime_ = -1;
  // Graph version: nodes and constraints made, the last solver update.
  int64_t graph_nodes_ = -1, graph_constraints_ = -1;
  size_t graph_updates_ = 0;
  int64_t stored_nodes_ = 0, stored_constraints_ = 0;
  size_t stored_updates_ = 0;
  int64_t tracked_steps_ = 0;
  bool restart_reported_ = false;
  MapperTiming timing_at_stats_;
  ComponentTimes extra_;   // store and publish, since the last MAPPER_STATS
  messages::Inbox inbox_;  // last: its handlers use the members above
};

}  // namespace evermap::mapper
