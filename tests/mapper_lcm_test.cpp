// mapper-proc's LCM adapter in one process over memq://: a simulated run is published message
// by message, the registration oracle answers on the same LCM, and what the mapper publishes
// (REGISTER_REQUEST, NODE_ADDED, POSE, MAP_GRAPH, MAPPER_STATS) and stores is checked. Garbage,
// out-of-order and non-finite messages slipped into the stream are dropped and counted, and
// the map comes out exactly as without them.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include <evermap/attitude_t.hpp>
#include <evermap/floor_t.hpp>
#include <evermap/map_graph_t.hpp>
#include <evermap/mapper_stats_t.hpp>
#include <evermap/node_added_t.hpp>
#include <evermap/pose_t.hpp>
#include <evermap/register_result_t.hpp>
#include <evermap/rgbd_calib_t.hpp>

#include "core/camera/calibration.h"
#include "core/messages/channels.h"
#include "core/messages/convert.h"
#include "mapper-proc/lcm_node.h"
#include "mapper-proc/map_store.h"
#include "tests/scratch_dir.h"
#include "tests/sim_test_support.h"
#include "tools/eval/alignment.h"
#include "tools/eval/metrics.h"
#include "tools/sim/oracle_server.h"
#include "tools/sim/run.h"

namespace evermap::mapper {
namespace {

// One session of ~3 simulated minutes on the 3-floor building.
sim::SimOptions shortRun() { return sim::testing::smallPatrol(5, 1, 0.04, 1, 1); }

struct Listener {
  std::vector<pose_t> poses;
  std::vector<map_graph_t> graphs;
  std::vector<mapper_stats_t> stats;
  std::vector<node_added_t> nodes;
  int64_t requests = 0;
  void onPose(const lcm::ReceiveBuffer*, const std::string&, const pose_t* m) {
    poses.push_back(*m);
  }
  void onGraph(const lcm::ReceiveBuffer*, const std::string&, const map_graph_t* m) {
    graphs.push_back(*m);
  }
  void onStats(const lcm::ReceiveBuffer*, const std::string&, const mapper_stats_t* m) {
    stats.push_back(*m);
  }
  void onNode(const lcm::ReceiveBuffer*, const std::string&, const node_added_t* m) {
    nodes.push_back(*m);
  }
  void onRequest(const lcm::ReceiveBuffer*, const std::string&) { ++requests; }
};

struct LiveRun {
  Listener heard;
  std::vector<MapperNode> nodes;
  std::map<int64_t, core::SE3d> truth_world_T_cam;  // by keyframe utime
  MapperStats stats;
  LcmNodeCounts counts;
  int64_t stored_nodes = 0;
  int64_t stored_edges = 0;
};

enum class Inject {
  kNothing,
  kBad,      // garbage, out-of-order, non-finite and stray messages after the 2000th
  kFarTime,  // well-formed copies stamped 2^62 first and after the 2000th (issue 17)
};

// Publishes the run on memq:// to the mapper and the oracle, with what `inject` says slipped
// in. Returns what the mapper did.
LiveRun runLive(Inject what, const std::filesystem::path& store_file, int* injected = nullptr) {
  const bool inject = what == Inject::kBad;
  LiveRun out;
  const sim::SimOptions sim_options = shortRun();
  auto plan = sim::RunPlan::create(sim_options);
  EXPECT_TRUE(plan) << plan.error().message;
  // The oracle knows every keyframe's truth up front, as evermap-sim-measure --oracle does.
  sim::OracleOptions oracle_options = sim_options.oracle;
  oracle_options.keyframe_window_s = 0.0;
  sim::RegistrationOracle oracle(oracle_options, plan->oracleSeed());
  sim::VectorSink log;
  sim::SessionObservers observers;
  observers.on_keyframe = [&](const sim::KeyframeTruth& k) {
    oracle.addKeyframe(k);
    out.truth_world_T_cam[k.utime] = k.world_T_cam;
  };
  (void)sim::generateRun(
      *plan, [&](int) -> sim::MessageSink& { return log; }, observers);

  lcm::LCM lcm("memq://");
  EXPECT_TRUE(lcm.good());
  sim::OracleServer server(lcm, oracle);
  MapperOptions options;
  options.tracker.body_T_cam = sim_options.sensors.camera.bodyTCam();
  Mapper mapper(options);
  auto store = MapStore::open(store_file);
  EXPECT_TRUE(store);
  LcmNodeOptions node_options;
  node_options.graph_period_s = 5.0;
  LcmNode node(lcm, mapper, node_options, &*store);
  Listener& h = out.heard;
  lcm.subscribe(channels::kPose, &Listener::onPose, &h);
  lcm.subscribe(channels::kMapGraph, &Listener::onGraph, &h);
  lcm.subscribe(channels::kMapperStats, &Listener::onStats, &h);
  lcm.subscribe(channels::kNodeAdded, &Listener::onNode, &h);
  lcm.subscribe(channels::kRegisterRequest, &Listener::onRequest, &h);

  auto drain = [&] {
    while (lcm.handleTimeout(0) > 0) {
    }
  };
  int count = 0;
  std::map<std::string, std::vector<uint8_t>> earlier;  // first message of each channel
  auto publishFarCopies = [&] {
    // A copy of the first message of each sensor channel, re-stamped 2^62 (utime is the first
    // field after the 8-byte hash, big-endian).
    for (const char* c :
         {channels::kVoDelta, channels::kWheelOdom, channels::kAttitude, channels::kFloor}) {
      for (const auto& m : log.messages) {
        if (m.channel != c) continue;
        std::vector<uint8_t> b = m.data;
        const uint64_t far = uint64_t{1} << 62;
        for (int k = 0; k < 8; ++k) b[8 + k] = static_cast<uint8_t>(far >> (56 - 8 * k));
        lcm.publish(c, b.data(), static_cast<unsigned>(b.size()));
        if (injected) ++*injected;
        break;
      }
    }
    drain();
  };
  if (what == Inject::kFarTime) publishFarCopies();
  for (const auto& m : log.messages) {
    earlier.emplace(m.channel, m.data);
    if (what == Inject::kFarTime && ++count == 2000) publishFarCopies();
    lcm.publish(m.channel, m.data.data(), static_cast<unsigned>(m.data.size()));
    drain();
    if (inject && ++count == 2000) {
      const uint8_t garbage[5] = {1, 2, 3, 4, 5};
      lcm.publish(channels::kVoDelta, garbage, sizeof garbage);  // undecodable
      for (const char* c : {channels::kWheelOdom, channels::kAttitude, channels::kVoDelta}) {
        const auto& old = earlier.at(c);  // out of order
        lcm.publish(c, old.data(), static_cast<unsigned>(old.size()));
      }
      attitude_t nan{};  // not finite
      nan.utime = m.utime + 1;
      nan.roll_rad = std::nan("");
      nan.covariance[0] = nan.covariance[3] = 1e-4;
      lcm.publish(channels::kAttitude, &nan);
      register_result_t stray{};  // no such request
      stray.utime = m.utime;
      stray.request_id = 999999;
      stray.status = register_result_t::STATUS_OK;
      lcm.publish(channels::kRegisterResult, &stray);
      floor_t high{};  // implausible
      high.utime = m.utime + 1;
      high.height_m = 5000.0;  // 5 km above the start floor: beyond floor_gate.max_height_m
      high.event = floor_t::EVENT_RIDE_END;
      lcm.publish(channels::kFloor, &high);
      *injected = 7;
      drain();
    }
  }
  node.flush();
  drain();
  out.nodes = mapper.nodes();
  out.stats = mapper.stats();
  out.counts = node.counts();
  auto snap = store->load();
  EXPECT_TRUE(snap);
  out.stored_nodes = static_cast<int64_t>(snap->nodes.size());
  out.stored_edges = snap->constraintsRepresented();
  return out;
}

TEST(MapperLcm, PublishesPoseGraphAndStatsAndStoresTheMapItBuilds) {
  evermap::testing::ScratchDir dir;
  const LiveRun r = runLive(Inject::kNothing, dir.path() / "map.db");
  const Listener& h = r.heard;
  ASSERT_GT(r.nodes.size(), 20u);
  EXPECT_GT(r.stats.loop_closures, 0);
  EXPECT_EQ(r.stats.dropped, 0);
  EXPECT_EQ(r.counts.undecodable, 0);
  // Every node announced, every step asked about, a pose per VO frame once mapping began.
  EXPECT_EQ(h.nodes.size(), r.nodes.size());
  EXPECT_EQ(h.requests, r.stats.requests_node + r.stats.requests_global);
  EXPECT_GT(h.poses.size(), 1000u);
  ASSERT_FALSE(h.graphs.empty());
  ASSERT_FALSE(h.stats.empty());

  // The last MAP_GRAPH is the final map: its nodes, one edge per node pair, its floors.
  const map_graph_t& g = h.graphs.back();
  ASSERT_EQ(g.num_nodes, static_cast<int32_t>(r.nodes.size()));
  EXPECT_EQ(g.num_edges, r.stats.factors);
  EXPECT_GE(g.num_edges, g.num_nodes - 1);
  EXPECT_EQ(g.num_floors, 3);
  int loops = 0;
  for (const auto& e : g.edges) {
    EXPECT_LT(e.from_node, e.to_node);
    EXPECT_GE(e.num_measurements, 1);
    loops += e.type == map_edge_t::TYPE_LOOP;
  }
  EXPECT_GT(loops, 0);
  // Graphs go out at most every 5 s of message time, and only after a change.
  for (size_t k = 1; k + 1 < h.graphs.size(); ++k)
    EXPECT_GE(h.graphs[k].utime - h.graphs[k - 1].utime, 5000000);

  // The map is right: node poses against the keyframes' truth (world_T_body), SE(3)-aligned.
  const core::SE3d cam_T_body = shortRun().sensors.camera.bodyTCam().inverse();
  std::vector<core::SE3d> gt, est;
  for (const auto& n : g.nodes) {
    gt.push_back(r.truth_world_T_cam.at(n.keyframe_utime) * cam_T_body);
    const Eigen::Quaterniond q(n.orientation[0], n.orientation[1], n.orientation[2],
                               n.orientation[3]);
    est.push_back(
        core::SE3d(q.normalized(), core::Vec3(n.position[0], n.position[1], n.position[2])));
  }
  auto aligned = eval::alignTrajectories(gt, est, eval::AlignmentMode::kSE3);
  ASSERT_TRUE(aligned);
  for (auto& e : est) e = aligned->gt_S_est * e;
  auto ate = eval::computeAte(gt, est);
  ASSERT_TRUE(ate);
  EXPECT_LT(ate->translation_m.rmse, 0.5);

  // MAPPER_STATS: counts of the final map and the per-component times.
  const mapper_stats_t& s = h.stats.back();
  EXPECT_EQ(s.num_nodes, g.num_nodes);
  EXPECT_EQ(s.num_edges, g.num_edges);
  EXPECT_EQ(s.num_floors, 3);
  EXPECT_EQ(s.num_sessions, 1);
  EXPECT_EQ(s.num_constraints, r.stats.constraints);
  EXPECT_EQ(s.num_dropped_messages, 0);
  ASSERT_EQ(s.num_components, 7);
  EXPECT_EQ(s.component_names[3], "solver");
  for (double ms : s.component_ms) EXPECT_GE(ms, 0.0);
  // The named counters: every counter of the mapper's stats, in text()'s order and with its
  // value, then every count of its tracker (one list each: mapper_stats.h, tracker_counts.h).
  ASSERT_EQ(s.counter_names.size(), s.counter_values.size());
  ASSERT_EQ(s.num_counters, static_cast<int32_t>(s.counter_names.size()));
  std::string listed;
  for (size_t k = 0; k < MapperStats::counters().size(); ++k)
    listed += s.counter_names[k] + " " + std::to_string(s.counter_values[k]) + "\n";
  EXPECT_EQ(listed, r.stats.text());
  ASSERT_EQ(s.counter_names.size(),
            MapperStats::counters().size() + TrackerCounts::counters().size());
  for (size_t k = 0; k < TrackerCounts::counters().size(); ++k)
    EXPECT_EQ(s.counter_names[MapperStats::counters().size() + k],
              TrackerCounts::counters()[k].name);
  // Nothing restarted, nothing implausible in a clean run.
  for (const char* zero :
       {"warm_restarts", "lost_restarts", "implausible_floors", "implausible_motion"}) {
    const auto at = std::find(s.counter_names.begin(), s.counter_names.end(), zero);
    ASSERT_NE(at, s.counter_names.end()) << zero;
    EXPECT_EQ(s.counter_values[static_cast<size_t>(at - s.counter_names.begin())], 0) << zero;
  }

  // The store holds the final map: every node, and every constraint (some folded).
  EXPECT_EQ(r.stored_nodes, g.num_nodes);
  EXPECT_EQ(r.stored_edges, r.stats.constraints);
}

// The same map, node for node: counts, and each node's keyframe, floor and position.
void expectSameGraph(const map_graph_t& a, const map_graph_t& b) {
  ASSERT_EQ(a.num_nodes, b.num_nodes);
  ASSERT_EQ(a.num_edges, b.num_edges);
  ASSERT_EQ(a.num_floors, b.num_floors);
  for (int i = 0; i < a.num_nodes; ++i) {
    EXPECT_EQ(a.nodes[i].keyframe_utime, b.nodes[i].keyframe_utime);
    EXPECT_EQ(a.nodes[i].floor, b.nodes[i].floor);
    for (int k = 0; k < 3; ++k) EXPECT_EQ(a.nodes[i].position[k], b.nodes[i].position[k]);
  }
}

// A clean run and one with `what` injected, each with its own store: `expected` messages were
// injected and MAPPER_STATS counts every one of them as dropped.
void runCleanAndInjected(Inject what, int expected, LiveRun* clean, LiveRun* injected) {
  evermap::testing::ScratchDir dir;
  *clean = runLive(Inject::kNothing, dir.path() / "clean.db");
  int count = 0;
  *injected = runLive(what, dir.path() / "injected.db", &count);
  ASSERT_EQ(count, expected);
  ASSERT_FALSE(injected->heard.stats.empty());
  EXPECT_EQ(injected->heard.stats.back().num_dropped_messages, expected);
}

// The last MAP_GRAPH of a run with messages injected is the clean run's, node for node.
void expectTheCleanMap(const LiveRun& clean, const LiveRun& injected) {
  ASSERT_FALSE(clean.heard.graphs.empty());
  ASSERT_FALSE(injected.heard.graphs.empty());
  const map_graph_t& a = clean.heard.graphs.back();
  const map_graph_t& b = injected.heard.graphs.back();
  ASSERT_NO_FATAL_FAILURE(expectSameGraph(a, b));
  EXPECT_EQ(a.utime, b.utime);  // the mapper's clock never left the stream's
}

TEST(MapperLcm, DropsAndCountsMalformedAndOutOfOrderMessagesWithoutApplyingThem) {
  LiveRun clean, dirty;
  ASSERT_NO_FATAL_FAILURE(runCleanAndInjected(Inject::kBad, 7, &clean, &dirty));
  EXPECT_EQ(dirty.counts.undecodable, 1);
  EXPECT_EQ(dirty.counts.refused, 6);
  EXPECT_EQ(dirty.stats.dropped, clean.stats.dropped + 6);
  EXPECT_EQ(dirty.stats.implausible_floors, 1);
  // The floor refusal is in MAPPER_STATS' named counters too.
  const mapper_stats_t& s = dirty.heard.stats.back();
  ASSERT_EQ(s.counter_names.size(), s.counter_values.size());
  const auto at = std::find(s.counter_names.begin(), s.counter_names.end(), "implausible_floors");
  ASSERT_NE(at, s.counter_names.end());
  EXPECT_EQ(s.counter_values[static_cast<size_t>(at - s.counter_names.begin())], 1);
  // Nothing of it reached the map: the same graph, node for node.
  expectTheCleanMap(clean, dirty);
}

TEST(MapperLcm, AMessageStampedTwoToThe62IsRefusedAndTheMapIsTheCleanRunsOne) {
  // Issue 17: one well-formed VO_DELTA / WHEEL_ODOM / ATTITUDE / FLOOR stamped 2^62, before the
  // stream and again in the middle of it, used to become the mapper's "now" (0 nodes from VO,
  // wrong floors, every attitude refused after it). The time guard holds them, no other
  // message confirms them, they are refused and counted; the map is the clean run's.
  LiveRun clean, far;
  ASSERT_NO_FATAL_FAILURE(runCleanAndInjected(Inject::kFarTime, 8, &clean, &far));
  EXPECT_EQ(far.counts.time_refused, 8);
  EXPECT_EQ(far.counts.undecodable, 0);
  EXPECT_EQ(far.stats.dropped, clean.stats.dropped);
  expectTheCleanMap(clean, far);
}

// A VO_DELTA that starts a keyframe at `utime` with no motion measured.
vo_delta_t keyframeWithoutMotion(int64_t utime) {
  vo_delta_t delta{};
  delta.utime = delta.ref_utime = utime;
  delta.status = vo_delta_t::STATUS_NO_DATA;
  delta.keyframe_changed = 1;
  delta.orientation[0] = 1.0;
  return delta;
}

TEST(MapperLcm, TakesTheCameraFromStereoCalibAndRefusesVoBeforeIt) {
  // The contract of docs/contracts.md: STEREO_CALIB is latched, repeated copies change
  // nothing, a bad one leaves the camera in use, and VO deltas wait for the first one.
  lcm::LCM lcm("memq://");
  ASSERT_TRUE(lcm.good());
  Mapper mapper(MapperOptions{});
  LcmNodeOptions node_options;
  node_options.input.time.confirm_count = 1;  // single messages here, not a stream to guard
  LcmNode node(lcm, mapper, node_options);
  auto drain = [&] {
    while (lcm.handleTimeout(0) > 0) {
    }
  };
  vo_delta_t first = keyframeWithoutMotion(1'000'000);
  lcm.publish(channels::kVoDelta, &first);
  drain();
  EXPECT_EQ(node.counts().no_calibration, 1);
  EXPECT_TRUE(mapper.nodes().empty());

  const core::SE3d body_T_cam = sim::CameraOptions{}.bodyTCam();
  const core::StereoCalibration calib = sim::CameraOptions{}.stereoCalibration(752, 480);
  for (int64_t t : {1'100'000, 2'100'000}) {  // the source repeats it every second
    const stereo_calib_t msg = messages::toMsg(calib, t);
    lcm.publish(channels::kStereoCalib, &msg);
  }
  drain();
  EXPECT_EQ(node.calibration().counts().camera_changes, 1);
  EXPECT_LT((mapper.tracker().bodyTCamera().inverse() * body_T_cam).log().norm(), 1e-12);
  stereo_calib_t bad = messages::toMsg(calib, 3'100'000);
  bad.left.fx = std::nan("");
  lcm.publish(channels::kStereoCalib, &bad);
  drain();
  EXPECT_EQ(node.calibration().counts().refused, 1);
  EXPECT_LT((mapper.tracker().bodyTCamera().inverse() * body_T_cam).log().norm(), 1e-12);

  first.utime = first.ref_utime = 3'200'000;
  lcm.publish(channels::kVoDelta, &first);
  drain();
  EXPECT_EQ(node.counts().no_calibration, 1);
  EXPECT_EQ(mapper.nodes().size(), 1u);
}

TEST(MapperLcm, TakesTheCameraFromRgbdCalibToo) {
  // An RGB-D camera (docs/rgbd.md): the mounting comes from RGBD_CALIB, latched the same way.
  lcm::LCM lcm("memq://");
  ASSERT_TRUE(lcm.good());
  Mapper mapper(MapperOptions{});
  LcmNodeOptions node_options;
  node_options.input.time.confirm_count = 1;
  LcmNode node(lcm, mapper, node_options);
  auto drain = [&] {
    while (lcm.handleTimeout(0) > 0) {
    }
  };
  core::CameraCalibration camera = sim::CameraOptions{}.stereoCalibration(640, 480).left;
  const core::SE3d body_T_cam = camera.body_T_cam;
  ASSERT_GT(body_T_cam.log().norm(), 1e-3);  // not the identity, so the test can fail
  for (int64_t t : {1'000'000, 2'000'000}) {
    rgbd_calib_t msg;
    msg.utime = t;
    msg.camera = messages::toMsg(camera);
    lcm.publish(channels::kRgbdCalib, &msg);
  }
  drain();
  EXPECT_EQ(node.calibration().counts().camera_changes, 1);
  EXPECT_LT((mapper.tracker().bodyTCamera().inverse() * body_T_cam).log().norm(), 1e-12);
  rgbd_calib_t bad;
  bad.utime = 3'000'000;
  bad.camera = messages::toMsg(camera);
  bad.camera.fx = -1.0;
  lcm.publish(channels::kRgbdCalib, &bad);
  drain();
  EXPECT_EQ(node.calibration().counts().refused, 1);
  const vo_delta_t first = keyframeWithoutMotion(3'100'000);
  lcm.publish(channels::kVoDelta, &first);
  drain();
  EXPECT_EQ(node.counts().no_calibration, 0);
  EXPECT_EQ(mapper.nodes().size(), 1u);
}

TEST(MapperLcm, RefusesBadPublishingPeriods) {
  LcmNodeOptions o;
  o.graph_period_s = -1.0;
  const Status s = o.validate();
  ASSERT_FALSE(s);
  EXPECT_NE(s.error().message.find("graph_period_s"), std::string::npos);
  o.graph_period_s = 1.0;
  o.stats_period_s = std::nan("");
  EXPECT_FALSE(o.validate());
}

}  // namespace
}  // namespace evermap::mapper
