// mapper-proc: continuing a stored map (Mapper::restore, the offline runner over a map
// store), and input validation at the Mapper API: malformed or out-of-order messages are
// dropped, counted and never applied.

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <optional>
#include <filesystem>

#include "mapper-proc/map_store.h"
#include "mapper-proc/mapper.h"
#include "tests/scratch_dir.h"
#include "tests/sim_test_support.h"
#include "tools/mapper-run/offline_run.h"

namespace evermap::mapper {
namespace {

using core::SE3d;
using core::Vec3;

// Two sessions over a three-floor building; the second starts at home, where the first
// mapped, and reaches the whole main floor.
sim::SimOptions twoSessions() { return sim::testing::smallPatrol(7, 2, 0.1, 2, 1); }

TEST(MapperRestore, ASecondSessionContinuesTheStoredMapAndAddsNodesOnlyWhereItIsNew) {
  evermap::testing::ScratchDir dir;
  OfflineRunOptions run;
  run.store_file = dir.path() / "map.db";
  run.first_session = run.last_session = 0;
  auto first = runOffline(twoSessions(), MapperOptions{}, run);
  ASSERT_TRUE(first) << first.error().message;
  ASSERT_GT(first->nodes, 20);

  run.first_session = run.last_session = 1;
  auto second = runOffline(twoSessions(), MapperOptions{}, run);
  ASSERT_TRUE(second) << second.error().message;
  EXPECT_EQ(second->restored_nodes, first->nodes);
  // Lost at the start, placed on the map by a global registration.
  EXPECT_GE(second->stats.relocalizations, 1);
  EXPECT_GT(second->stats.loop_closures, 10);
  ASSERT_EQ(second->nodes_by_session.size(), 2u);
  EXPECT_EQ(second->nodes_by_session[0], first->nodes);
  const int64_t added = second->nodes_by_session[1];
  // No node where session 1 already had one (within 1 m and π/8), beyond 5 % of the new ones.
  EXPECT_LE(second->nodes_in_mapped_area_by_session[1] * 20, std::max<int64_t>(added, 1));
  EXPECT_LT(second->ate_rmse_m, 0.5);
  EXPECT_EQ(second->stats.dropped, 0);

  // The file holds both sessions' nodes and every constraint (some folded), and passes the
  // integrity check.
  auto store = MapStore::open(run.store_file);
  ASSERT_TRUE(store) << store.error().message;
  ASSERT_TRUE(store->integrityCheck());
  auto snap = store->load();
  ASSERT_TRUE(snap) << snap.error().message;
  EXPECT_EQ(static_cast<int64_t>(snap->nodes.size()), second->nodes);
  // (The second mapper restored the first session's rows, folds as one constraint each.)
  EXPECT_EQ(snap->constraintsRepresented(),
            first->constraints + second->constraints - second->stats.restored_constraints);
}

// mapper-proc killed mid-session on an upper floor and restarted live: no FLOOR message tells
// the new process where it is (elevator-proc announces rides only). It relocalises against
// its store, learns its floor from the map, and the map keeps growing.
TEST(MapperRestore, AMapperRestartedMidSessionOnAnUpperFloorRelocalisesAndKeepsMapping) {
  evermap::testing::ScratchDir dir;
  OfflineRunOptions run;
  run.store_file = dir.path() / "map.db";
  run.first_session = run.last_session = 0;
  // The first stop (20 s apart) where the exploration tour (about 300 s) is on a floor other
  // than 0 (what a mapper that no FLOOR message has told its floor would take).
  std::optional<OfflineRunSummary> killed;
  for (double stop_s = 60.0; stop_s <= 240.0 && !killed; stop_s += 20.0) {
    std::filesystem::remove(run.store_file);
    run.stop_after_s = stop_s;
    auto first = runOffline(twoSessions(), MapperOptions{}, run);
    ASSERT_TRUE(first) << first.error().message;
    ASSERT_TRUE(first->stopped_early);
    if (first->final_floor > 0) killed = *first;
  }
  ASSERT_TRUE(killed) << "the session never left its first floor";

  run.stop_after_s = 0.0;
  run.floors_before_resume = false;  // a live restart: the log is not replayed to it
  // The cold start (the store's tracking state not used): what a restart beyond
  // warm_restart_max_gap_s, or from a store without the state, does.
  MapperOptions cold;
  cold.warm_restart_max_gap_s = 0.0;
  const std::filesystem::path warm_copy = dir.path() / "warm.db";
  std::filesystem::copy_file(run.store_file, warm_copy);
  auto resumed = runOffline(twoSessions(), cold, run);
  ASSERT_TRUE(resumed) << resumed.error().message;
  EXPECT_EQ(resumed->restored_nodes, killed->nodes);
  EXPECT_EQ(resumed->stats.lost_restarts, 1);
  EXPECT_GE(resumed->stats.relocalizations, 1);
  EXPECT_GT(resumed->stats.loop_closures, 0);
  EXPECT_GT(resumed->nodes, killed->nodes + 20);  // mapping went on
  EXPECT_EQ(resumed->final_floor, killed->final_floor);
  EXPECT_LT(resumed->ate_rmse_m, 0.5);

  // The same restart, warm, after the 6 s of messages a 20x replay loses while the deputy
  // restarts mapper-proc. VO went on through the gap: the odometry frame bridges it, tracking
  // resumes on the saved floor where the robot is, without a relocalisation or a
  // confirmation, and mapping goes on at once.
  const std::filesystem::path inflated_copy = dir.path() / "inflated.db";
  std::filesystem::copy_file(warm_copy, inflated_copy);
  run.store_file = warm_copy;
  run.restart_gap_s = 6.0;
  auto warm = runOffline(twoSessions(), MapperOptions{}, run);
  ASSERT_TRUE(warm) << warm.error().message;
  EXPECT_EQ(warm->stats.warm_restarts, 1);
  EXPECT_EQ(warm->stats.warm_bridged, 1) << warm->restart_note;
  EXPECT_EQ(warm->stats.relocalizations, 0);
  EXPECT_EQ(warm->stats.warm_confirmations, 0);
  EXPECT_GT(warm->nodes, killed->nodes + 20);
  EXPECT_EQ(warm->final_floor, killed->final_floor);
  EXPECT_LT(warm->ate_rmse_m, 0.5);

  // Without the bridge (an odometry source without the frame): the pose (σ 9 m) is too
  // uncertain for nodes until two registrations confirm it, which here, exploring, takes most
  // of the rest of the session (the cold start was luckier: its first candidate was confirmed
  // at once).
  MapperOptions inflated;
  inflated.warm_restart_bridge = false;
  run.store_file = inflated_copy;
  auto held = runOffline(twoSessions(), inflated, run);
  ASSERT_TRUE(held) << held.error().message;
  EXPECT_EQ(held->stats.warm_restarts, 1);
  EXPECT_EQ(held->stats.warm_bridged, 0);
  EXPECT_EQ(held->stats.relocalizations, 0);
  EXPECT_GE(held->stats.warm_confirmations, 1);
  EXPECT_LT(held->nodes, warm->nodes);
  EXPECT_EQ(held->final_floor, killed->final_floor);
  EXPECT_LT(held->ate_rmse_m, 0.5);
}

TEST(MapperRestore, ReplaysEveryStoredConstraintIntoTheSameMergedPairs) {
  evermap::testing::ScratchDir dir;
  OfflineRunOptions run;
  run.store_file = dir.path() / "map.db";
  run.last_session = 0;
  auto first = runOffline(twoSessions(), MapperOptions{}, run);
  ASSERT_TRUE(first) << first.error().message;
  auto store = MapStore::open(run.store_file);
  ASSERT_TRUE(store);
  auto snap = store->load();
  ASSERT_TRUE(snap);

  Mapper m{MapperOptions{}};
  ASSERT_TRUE(m.restore(*snap));
  EXPECT_TRUE(m.lost());
  EXPECT_EQ(m.session(), 1);
  ASSERT_EQ(m.nodes().size(), snap->nodes.size());
  ASSERT_EQ(m.constraints().all().size(), snap->edges.size());
  // The same merge and rejection decisions as when the constraints were made; a fold (a
  // pair's rows once it had three) is its pair's first constraint and stands for the merges
  // and rejections of its members.
  int64_t folds = 0, folded_merges = 0, folded_rejections = 0;
  for (size_t k = 0; k < snap->edges.size(); ++k) {
    const StoredEdge& e = snap->edges[k];
    EXPECT_EQ(m.constraints().all()[k].accepted, e.constraint.accepted) << "edge " << e.edge_id;
    if (e.folded > 0) {
      ++folds;
      folded_merges += e.folded - 1;
      folded_rejections += e.folded_rejected;
    }
  }
  EXPECT_GT(folds, 0);
  EXPECT_EQ(m.constraints().merged() + folded_merges, first->stats.merged);
  EXPECT_EQ(m.constraints().rejected() + folded_rejections, first->stats.rejected_inconsistent);
  EXPECT_EQ(m.stats().factors, first->factors);
  // Re-solved with the same factors (roll/pitch ones included): the nodes stay where they
  // were, up to the difference between the live incremental estimate and one batch step from
  // it (a few centimetres on loops held by the robust kernel); a wrong replay moves metres.
  double worst = 0.0;
  for (const StoredNode& n : snap->nodes)
    worst = std::max(worst,
                     (m.nodePose(n.node.id).translation() - n.world_T_body.translation()).norm());
  EXPECT_LT(worst, 0.1);
  // The roll/pitch factors came back from the store with their nodes.
  size_t with_attitude = 0;
  for (const MapperNode& n : m.nodes()) with_attitude += n.attitude ? 1 : 0;
  EXPECT_GT(with_attitude, m.nodes().size() / 2);
  for (const StoredNode& n : snap->nodes)
    EXPECT_EQ(m.nodes()[n.node.id].attitude.has_value(), n.node.attitude.has_value());
  // A second restore, or one into a mapper that has a map, is refused.
  EXPECT_FALSE(m.restore(*snap));
}

TEST(MapperRestore, RefusesAMapWhoseEdgesNameUnknownNodes) {
  MapSnapshot snap;
  StoredNode n;
  n.node.id = 0;
  snap.nodes.push_back(n);
  StoredEdge e;
  e.constraint.from = 0;
  e.constraint.to = 5;
  e.constraint.from_T_to.covariance = core::Mat6::Identity() * 1e-4;
  snap.edges.push_back(e);
  Mapper m{MapperOptions{}};
  const Status s = m.restore(snap);
  ASSERT_FALSE(s);
  EXPECT_NE(s.error().message.find("edge 0"), std::string::npos);
  EXPECT_TRUE(m.nodes().empty());

  MapSnapshot gap;
  n.node.id = 3;
  gap.nodes.push_back(n);
  EXPECT_FALSE(Mapper{MapperOptions{}}.restore(gap));
}

// ---- input validation ---------------------------------------------------------------------

vo_delta_t vo(int64_t utime, int64_t ref, double dx, bool keyframe) {
  vo_delta_t m{};
  m.utime = utime;
  m.ref_utime = ref;
  m.status = vo_delta_t::STATUS_OK;
  m.keyframe_changed = keyframe ? 1 : 0;
  m.translation[0] = dx;
  m.orientation[0] = 1.0;
  for (int i = 0; i < 6; ++i) m.covariance[7 * i] = 1e-6;
  return m;
}

// A mapper with a first node, tracking VO, and one step in flight; expects its state to stay
// exactly as it is across messages that must be dropped.
class MapperInput : public ::testing::Test {
 protected:
  void SetUp() override {
    floor_t f{};
    f.utime = 1;
    ASSERT_TRUE(m_.onFloor(f));
    vo_delta_t start = vo(1'000'000, 1'000'000, 0, true);
    start.status = vo_delta_t::STATUS_NO_DATA;  // the first frame: a reference keyframe
    ASSERT_TRUE(m_.onVo(start));
    ASSERT_TRUE(m_.onVo(vo(2'000'000, 1'000'000, 0.3, true)));  // a step: one request
    ASSERT_TRUE(m_.onVo(vo(2'100'000, 2'000'000, 0.05, false)));
    requests_ = m_.takeRequests();
    ASSERT_EQ(requests_.size(), 1u);
  }
  void expectUnchanged(int64_t dropped) {
    EXPECT_EQ(m_.stats().dropped, dropped);
    EXPECT_EQ(m_.nodes().size(), 1u);
    EXPECT_EQ(m_.stats().steps, 2);
    const auto d = m_.tracker().delta();
    EXPECT_LT((d.mean.translation() - Vec3(0.35, 0, 0)).norm(), 1e-12);
    EXPECT_TRUE(d.covariance.allFinite());
    EXPECT_EQ(m_.tracker().lastUtime(), 2'100'000);
    EXPECT_TRUE(m_.takeRequests().empty());
  }
  // A well-formed successful answer to the request in flight: node 0, identity pose.
  register_result_t okAnswer() const {
    const register_request_t& r = requests_.front();
    register_result_t ok{};
    ok.utime = r.utime;
    ok.request_id = r.request_id;
    ok.keyframe_utime = r.keyframe_utime;
    ok.status = register_result_t::STATUS_OK;
    ok.node_id = 0;
    ok.orientation[0] = 1.0;
    for (int i = 0; i < 6; ++i) ok.covariance[7 * i] = 1e-4;
    return ok;
  }
  Mapper m_{MapperOptions{}};
  std::vector<register_request_t> requests_;
};

TEST_F(MapperInput, DropsMalformedVoWithoutApplyingIt) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  vo_delta_t m = vo(2'200'000, 2'000'000, nan, false);
  EXPECT_FALSE(m_.onVo(m));  // NaN in the delta
  m = vo(2'200'000, 2'000'000, 0.1, false);
  m.orientation[2] = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(m_.onVo(m));
  m = vo(2'200'000, 2'000'000, 0.1, false);
  m.orientation[0] = 0.5;  // not a unit quaternion
  EXPECT_FALSE(m_.onVo(m));
  m = vo(2'200'000, 2'000'000, 0.1, false);
  m.covariance[0] = -1.0;  // not positive semi-definite
  EXPECT_FALSE(m_.onVo(m));
  m = vo(2'200'000, 2'000'000, 0.1, false);
  m.covariance[1] = 1e-3;  // not symmetric
  EXPECT_FALSE(m_.onVo(m));
  m = vo(2'200'000, 2'000'000, 0.1, false);
  m.covariance[14] = nan;
  EXPECT_FALSE(m_.onVo(m));
  EXPECT_FALSE(m_.onVo(vo(2'050'000, 2'000'000, 0.1, false)));  // older than the last frame
  EXPECT_FALSE(m_.onVo(vo(2'100'000, 2'000'000, 0.1, false)));  // the same time again
  // A reference after the frame (an unknown one earlier is reanchored: docs/contracts.md).
  EXPECT_FALSE(m_.onVo(vo(2'200'000, 2'300'000, 0.1, false)));
  expectUnchanged(9);
  // A malformed frame did not move the clock: the next good frame applies.
  ASSERT_TRUE(m_.onVo(vo(2'200'000, 2'000'000, 0.1, false)));
  EXPECT_LT((m_.tracker().delta().mean.translation() - Vec3(0.4, 0, 0)).norm(), 1e-12);
}

TEST_F(MapperInput, DropsMalformedWheelAttitudeAndFloorMessages) {
  wheel_odom_t w{};
  w.utime = 2'000'000;
  w.prev_utime = 1'900'000;
  w.delta_x_m = 0.1;
  w.covariance[0] = w.covariance[4] = w.covariance[8] = 1e-4;
  ASSERT_TRUE(m_.onWheel(w));  // VO is tracking: accepted, not compounded
  wheel_odom_t bad = w;
  bad.utime = 1'950'000;  // out of order
  EXPECT_FALSE(m_.onWheel(bad));
  bad = w;
  bad.utime = 2'100'000;
  bad.delta_theta_rad = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(m_.onWheel(bad));
  bad.delta_theta_rad = 0.0;
  bad.covariance[4] = -1.0;
  EXPECT_FALSE(m_.onWheel(bad));
  bad.covariance[4] = 1e-4;
  bad.prev_utime = 2'200'000;  // an increment that ends before it starts
  EXPECT_FALSE(m_.onWheel(bad));

  attitude_t a{};
  a.utime = 2'000'000;
  a.covariance[0] = a.covariance[3] = 1e-4;
  a.accel_trusted = 1;
  ASSERT_TRUE(m_.onAttitude(a));
  attitude_t b = a;
  EXPECT_FALSE(m_.onAttitude(b));  // not newer
  b.utime = 2'100'000;
  b.covariance[1] = b.covariance[2] = 1.0;  // not positive definite
  EXPECT_FALSE(m_.onAttitude(b));
  b.covariance[1] = b.covariance[2] = 0.0;
  b.pitch_rad = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(m_.onAttitude(b));

  floor_t f{};
  f.utime = 0;  // before the first FLOOR
  EXPECT_FALSE(m_.onFloor(f));
  f.utime = 2'000'000;
  f.height_sigma_m = -1.0;
  EXPECT_FALSE(m_.onFloor(f));
  f.height_sigma_m = 0.0;
  f.height_m = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(m_.onFloor(f));
  expectUnchanged(10);
  EXPECT_EQ(m_.floors().size(), 1u);
  EXPECT_EQ(m_.floors().at(0), 0.0);
}

TEST_F(MapperInput, DropsRegistrationResultsThatAreStaleOrMalformed) {
  const register_request_t& r = requests_.front();
  const register_result_t ok = okAnswer();

  register_result_t stale = ok;
  stale.request_id = r.request_id + 7;  // no such request
  EXPECT_FALSE(m_.onRegisterResult(stale));
  stale = ok;
  stale.keyframe_utime = r.keyframe_utime - 1;  // the right id for another keyframe
  EXPECT_FALSE(m_.onRegisterResult(stale));
  expectUnchanged(2);

  // A malformed answer to the request in flight: dropped, the step closes unregistered (the
  // new place gets its node from Δ, not from the answer).
  register_result_t bad = ok;
  bad.translation[1] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(m_.onRegisterResult(bad));
  EXPECT_EQ(m_.stats().dropped, 3);
  EXPECT_EQ(m_.stats().registrations_ok, 0);
  EXPECT_EQ(m_.stats().loop_closures + m_.stats().delta_replaced + m_.stats().delta_kept +
                m_.stats().delta_fused,
            0);
  // The same answer once more: nothing in flight any more.
  EXPECT_FALSE(m_.onRegisterResult(ok));
  EXPECT_EQ(m_.stats().dropped, 4);
}

TEST_F(MapperInput, DropsAnAnswerWithAZeroQuaternionOrABadCovariance) {
  register_result_t bad = okAnswer();
  bad.orientation[0] = 0.0;  // quaternion all zero
  EXPECT_FALSE(m_.onRegisterResult(bad));
  EXPECT_EQ(m_.stats().registrations_ok, 0);
  EXPECT_EQ(m_.stats().dropped, 1);
  EXPECT_TRUE(m_.tracker().delta().mean.translation().allFinite());
}

}  // namespace
}  // namespace evermap::mapper
