#include "mapper-proc/lcm_node.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <set>
#include <sstream>

#include <evermap/attitude_t.hpp>
#include <evermap/rgbd_calib_t.hpp>
#include <evermap/floor_t.hpp>
#include <evermap/register_result_t.hpp>
#include <evermap/vo_delta_t.hpp>
#include <evermap/wheel_odom_t.hpp>

#include "core/common/clocks.h"
#include "core/messages/channels.h"
#include "core/messages/convert.h"
#include "core/messages/pose_fields.h"

namespace evermap::mapper {
namespace {

using messages::putPose;

}  // namespace

Status LcmNodeOptions::validate() const {
  if (!(graph_period_s >= 0.0) || !std::isfinite(graph_period_s))
    return makeError("graph_period_s: must be a finite number >= 0, got ", graph_period_s);
  if (!(stats_period_s >= 0.0) || !std::isfinite(stats_period_s))
    return makeError("stats_period_s: must be a finite number >= 0, got ", stats_period_s);
  if (Status s = input.validate(); !s) return makeError("input: ", s.error().message);
  return Ok{};
}

map_graph_t graphMessage(const Mapper& mapper, int64_t utime) {
  map_graph_t g{};
  g.utime = utime;
  // A quarantined session's nodes are kept (the store, the graph) but are no part of the map.
  for (const MapperNode& n : mapper.nodes()) {
    if (mapper.quarantined(n.id)) continue;
    map_node_t m{};
    m.node_id = n.id;
    m.keyframe_utime = n.keyframe_utime;
    putPose(mapper.nodePose(n.id), m.position, m.orientation);
    m.floor = n.floor;
    m.session = n.session;
    g.nodes.push_back(m);
  }
  const auto& all = mapper.constraints().all();
  for (const auto& [key, pair] : mapper.constraints().pairs()) {
    if (mapper.quarantined(pair.i) || mapper.quarantined(pair.j)) continue;
    map_edge_t e{};
    e.from_node = pair.i;
    e.to_node = pair.j;
    e.type = map_edge_t::TYPE_ODOMETRY;
    for (size_t k : pair.members) {
      if (!all[k].accepted) continue;
      ++e.num_measurements;
      if (all[k].kind == ConstraintKind::kLoop) e.type = map_edge_t::TYPE_LOOP;
    }
    putPose(pair.i_T_j.mean, e.translation, e.orientation);
    g.edges.push_back(e);
  }
  for (const auto& [index, height] : mapper.floors())
    g.floors.push_back(map_floor_t{index, height});
  g.num_nodes = static_cast<int32_t>(g.nodes.size());
  g.num_edges = static_cast<int32_t>(g.edges.size());
  g.num_floors = static_cast<int32_t>(g.floors.size());
  return g;
}

LcmNode::LcmNode(lcm::LCM& lcm, Mapper& mapper, const LcmNodeOptions& options, MapStore* store)
    : lcm_(lcm),
      out_(lcm, options.input.signer),
      m_(mapper),
      o_(options),
      store_(store),
      timing_at_stats_(mapper.stats().timing),
      inbox_(lcm, options.input) {
  auto on = [this](const auto& msg) { return this->on(msg); };
  subscribeMapInputs(inbox_, on);
  inbox_.subscribeBytes<stereo_calib_t>(
      channels::kStereoCalib,
      [this](const void* data, int64_t size) { return onCalibration(data, size); });
  inbox_.subscribeBytes<rgbd_calib_t>(channels::kRgbdCalib, [this](const void* data, int64_t size) {
    return calibration_.handleRgbd(data, size, m_);
  });
}

LcmNodeCounts LcmNode::counts() const {
  LcmNodeCounts c = counts_;
  for (const auto& [channel, k] : inbox_.counts()) {
    c.received[channel] = k.received;
    c.undecodable += k.malformed;
    c.time_refused += k.time_refused;
    c.failed += k.failed;
  }
  // The latch counts its own refusals; the Inbox counted them as refused too.
  return c;
}

Status LcmNode::onCalibration(const void* data, int64_t size) {
  return calibration_.handle(data, size, m_);
}

template <typename Msg>
Status LcmNode::on(const Msg& msg) {
  if constexpr (std::is_same_v<Msg, vo_delta_t>) {
    if (!calibration_.haveCamera()) {
      // The deltas are camera motions: without the mounting they cannot be used.
      ++counts_.no_calibration;
      return makeError("VO_DELTA ", msg.utime, ": no STEREO_CALIB received yet (",
                       counts_.no_calibration, " so far)");
    }
  }
  if (Status s = deliver(m_, msg); !s) {
    ++counts_.refused;  // the mapper counted it too
    return s;
  }
  afterMessage(messageTime(msg, last_utime_), movesPose<Msg>(m_.tracker().voTracking()));
  return Ok{};
}

void LcmNode::afterMessage(int64_t utime, bool publish_pose) {
  const auto t0 = SteadyClock::now();
  if (!restart_reported_ && m_.restartGapS()) {
    // One line per start from a stored state (a killed process prints no summary).
    restart_reported_ = true;
    if (*m_.restartGapS() < 0.0)
      std::printf("evermap-mapper-proc: lost restart: no usable tracking state (%s)\n",
                  m_.restartNote().c_str());
    else
      std::printf(
          "evermap-mapper-proc: %s restart: %.2f s of message time since the saved tracking state "
          "(%s)\n",
          m_.stats().warm_restarts > 0 ? "warm" : "lost", *m_.restartGapS(),
          m_.restartNote().c_str());
    std::fflush(stdout);
  }
  for (const std::string& line : m_.takeNotes())
    std::printf("evermap-mapper-proc: %s\n", line.c_str());
  last_utime_ = std::max(last_utime_, utime);
  for (const auto& r : m_.takeRequests()) out_.publish(channels::kRegisterRequest, r);
  for (const auto& n : m_.takeNodesAdded()) out_.publish(channels::kNodeAdded, n);
  // Not while lost, nor while a warm restart's placement is unconfirmed: that pose is the
  // saved one, metres off by what the robot drove during the restart (its covariance says so,
  // but a consumer of POSE should not have to judge it).
  if (publish_pose && m_.activeNode() >= 0 && !m_.lost() && !m_.resumedUnconfirmed()) {
    const int session = m_.nodes().empty() ? -1 : m_.nodes().back().session;
    const pose_t p = messages::toMsg(utime, m_.pose(), m_.floor(), session);
    out_.publish(channels::kPose, p);
    ++counts_.poses;
  }
  extra_.publish_s += secondsSince(t0);
  save();
  if (last_graph_utime_ < 0 || last_utime_ - last_graph_utime_ >= micros(o_.graph_period_s))
    publishGraph();
  if (last_stats_utime_ < 0 || last_utime_ - last_stats_utime_ >= micros(o_.stats_period_s))
    publishStats();
}

void LcmNode::save() {
  const MapperStats& st = m_.stats();
  if (!store_ || !store_status_ || m_.nodes().empty()) return;
  if (st.nodes == stored_nodes_ && st.constraints == stored_constraints_ &&
      st.timing.update_s.size() == stored_updates_) {
    // The graph as stored, the robot moved on: the tracking state alone, once per step
    // (2 Hz of message time), so a restart resumes from at most a step ago.
    if (st.steps == tracked_steps_) return;
    tracked_steps_ = st.steps;
    const auto t0 = SteadyClock::now();
    if (Status s = store_->saveTracking(m_); !s) {
      // Not the map: a failure here costs a warm restart at most; the next save retries.
      ++counts_.tracking_failures;
    }
    ++counts_.tracking_transactions;
    extra_.store_s += secondsSince(t0);
    return;
  }
  tracked_steps_ = st.steps;
  const auto t0 = SteadyClock::now();
  // The session of the newest node, started at that session's first node.
  const int session = m_.nodes().back().session;
  int64_t start = m_.nodes().back().keyframe_utime;
  for (auto it = m_.nodes().rbegin(); it != m_.nodes().rend() && it->session == session; ++it)
    start = it->keyframe_utime;
  store_status_ = store_->save(m_, session, start);
  if (!store_status_)
    std::fprintf(stderr, "evermap-mapper-proc: map store: %s (no more writes)\n",
                 store_status_.error().message.c_str());
  stored_nodes_ = st.nodes;
  stored_constraints_ = st.constraints;
  stored_updates_ = st.timing.update_s.size();
  ++counts_.store_transactions;
  extra_.store_s += secondsSince(t0);
}

void LcmNode::publishGraph() {
  const MapperStats& st = m_.stats();
  if (st.nodes == graph_nodes_ && st.constraints == graph_constraints_ &&
      st.timing.update_s.size() == graph_updates_)
    return;
  const auto t0 = SteadyClock::now();
  const map_graph_t g = graphMessage(m_, last_utime_);
  out_.publish(channels::kMapGraph, g);
  graph_nodes_ = st.nodes;
  graph_constraints_ = st.constraints;
  graph_updates_ = st.timing.update_s.size();
  last_graph_utime_ = last_utime_;
  ++counts_.graphs;
  extra_.publish_s += secondsSince(t0);
}

void LcmNode::publishStats() {
  const MapperStats& st = m_.stats();
  const MapperTiming& t = st.timing;
  mapper_stats_t s{};
  s.utime = last_utime_;
  s.num_nodes = static_cast<int32_t>(m_.nodes().size());
  s.num_edges = static_cast<int32_t>(m_.constraints().pairs().size());
  s.num_floors = static_cast<int32_t>(m_.floors().size());
  std::set<int> sessions;
  for (const MapperNode& n : m_.nodes()) sessions.insert(n.session);
  s.num_sessions = static_cast<int32_t>(sessions.size());
  s.num_constraints = st.constraints;
  s.num_rejected = st.rejected_inconsistent + st.rejected_map_gate;
  // The mapper's count covers what it refused; undecodable messages never reached it.
  const messages::ChannelCounts in = inbox_.total();
  s.num_dropped_messages = st.dropped + in.malformed + in.time_refused + in.failed +
                           counts_.no_calibration + calibration_.counts().undecodable +
                           calibration_.counts().refused;
  const std::pair<const char*, double> components[] = {
      {"tracking", t.tracking_s - timing_at_stats_.tracking_s},
      {"registration", t.registration_s - timing_at_stats_.registration_s},
      {"partition", t.partition_s - timing_at_stats_.partition_s},
      {"solver", t.solver_s - timing_at_stats_.solver_s},
      {"store", extra_.store_s},
      {"publish", extra_.publish_s},
      // The solver time of the newest update alone (the paper's Fig. 7 quantity).
      {"solver_last_update", t.update_s.empty() ? 0.0 : t.update_s.back()},
  };
  for (const auto& [name, seconds] : components) {
    s.component_names.emplace_back(name);
    s.component_ms.push_back(1e3 * seconds);
  }
  s.num_components = static_cast<int32_t>(s.component_names.size());
  // Every counter of the mapper and of its tracker, named as in the summaries.
  const auto add = [&s](std::string_view name, int64_t value) {
    s.counter_names.emplace_back(name);
    s.counter_values.push_back(value);
  };
  for (const MapperStats::Counter& c : MapperStats::counters()) add(c.name, st.*c.field);
  const TrackerCounts& tracked = m_.tracker().counts();
  for (const TrackerCounts::Counter& c : TrackerCounts::counters()) add(c.name, tracked.*c.field);
  s.num_counters = static_cast<int32_t>(s.counter_names.size());
  out_.publish(channels::kMapperStats, s);
  const input_stats_t input = inbox_.statsMessage(last_utime_);
  out_.publish(channels::kInputStats, input);
  timing_at_stats_ = MapperTiming{};
  timing_at_stats_.tracking_s = t.tracking_s;
  timing_at_stats_.registration_s = t.registration_s;
  timing_at_stats_.partition_s = t.partition_s;
  timing_at_stats_.solver_s = t.solver_s;
  extra_ = ComponentTimes{};
  last_stats_utime_ = last_utime_;
  ++counts_.stats;
}

void LcmNode::flush() {
  save();
  publishGraph();
  publishStats();
}

std::string LcmNode::summary() const {
  std::ostringstream s;
  s << m_.stats().text();
  const LcmNodeCounts c = counts();
  for (const auto& [channel, n] : c.received) s << "received_" << channel << " " << n << "\n";
  s << "undecodable " << c.undecodable << "\ntime_refused " << c.time_refused << "\nhandler_failed "
    << c.failed << "\nrefused " << c.refused << "\nposes_published " << counts_.poses
    << "\nvo_before_calibration " << counts_.no_calibration << "\ncalibrations_refused "
    << calibration_.counts().refused << "\ncamera_changes " << calibration_.counts().camera_changes
    << "\ngraphs_published " << counts_.graphs << "\nstats_published " << counts_.stats
    << "\nstore_transactions " << counts_.store_transactions << "\ntracking_transactions "
    << counts_.tracking_transactions << "\ntracking_failures " << counts_.tracking_failures << "\n";
  // The envelopes refused (core/messages/sender_check.h), then the input per channel.
  const messages::ChannelCounts in = inbox_.total();
  s << "unauthenticated " << in.unauthenticated << "\nreplayed " << in.replayed << "\nother_sender "
    << in.other_sender << "\ninput " << inbox_.summary() << "\n";
  const TrackerCounts& t = m_.tracker().counts();
  for (const TrackerCounts::Counter& k : TrackerCounts::counters())
    s << k.name << " " << t.*k.field << "\n";
  return s.str();
}

}  // namespace evermap::mapper
