// mapper-proc: Algorithm 1 on a scripted drive, and the reduced against the full pose graph on
// a simulated run (the tracker and the constraint set: mapper_tracker_test; the map store:
// map_store_test).

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>
#include <set>
#include <sstream>
#include <string>

#include "mapper-proc/constraint_set.h"
#include "mapper-proc/map_store.h"
#include "mapper-proc/mapper.h"
#include "mapper-proc/tracker.h"
#include "tests/mapper_messages.h"
#include "tests/scratch_dir.h"
#include "tests/scripted_drive.h"
#include "tests/sim_test_support.h"
#include "tools/mapper-run/offline_run.h"
#include "tools/mapper-run/run_metrics.h"
#include "tools/sim/registration_oracle.h"

namespace evermap::mapper {
namespace {

using namespace testing;  // tests/mapper_messages.h, tests/scripted_drive.h

TEST(ReducedGraph, RevisitAddsConstraintNotNode) {
  ScriptedDrive drive(scriptedOptions());
  lap(drive);
  const int64_t nodes_after_first = drive.mapper().stats().nodes;
  const int64_t constraints_after_first = drive.mapper().stats().constraints;
  const int64_t closures_after_first = drive.mapper().stats().loop_closures;
  ASSERT_GT(nodes_after_first, 10);
  lap(drive);
  // The turns' steps come at other headings each lap: one may fall between two of the first
  // lap's nodes, more than the overlap (45°) from both. Once covered, no more.
  EXPECT_LE(drive.mapper().stats().nodes, nodes_after_first + 2);
  const int64_t nodes_after_second = drive.mapper().stats().nodes;
  lap(drive);
  EXPECT_EQ(drive.mapper().stats().nodes, nodes_after_second);
  EXPECT_GT(drive.mapper().stats().constraints, constraints_after_first);
  EXPECT_GT(drive.mapper().stats().loop_closures, closures_after_first);
  EXPECT_EQ(drive.mapper().stats().rejected_inconsistent, 0);
  // Exact measurements: the map is exact. The origin is the first frame, 0.1 m along x.
  const SE3d end = drive.mapper().pose().mean;
  EXPECT_LT((end.translation() - Vec3(-0.1, 0, 0)).norm(), 1e-6);
  EXPECT_LT(core::rotationAngle(end.so3()), 1e-6);
}

// A lap, then the corridor again `offset_m` to the side, where registrations fail (a dark
// stretch): the map's frame is the first node's, so the first line is at y = 0 and the
// second at y = -offset_m (0.2 m: across the cell edge there, within the overlap of the first's
// nodes, about 1.5 m apart), to x = end_x. The nodes the dark pass adds.
int64_t nodesAddedBeside(const MapperOptions& o, double offset_m, double end_x = 8.0) {
  ScriptedDrive drive(o);
  drive.sidestep(0.3);
  lap(drive);
  const int64_t before = drive.mapper().stats().nodes;
  EXPECT_GT(before, 4);
  drive.sidestep(-offset_m);
  drive.blind(true);
  drive.driveTo(end_x, 0.0);
  return drive.mapper().stats().nodes - before;
}

TEST(ReducedGraph, APlaceSeenAcrossACellEdgeAddsNoNodeWhileAnotherOverlapsIt) {
  MapperOptions cells_only = scriptedOptions();
  cells_only.overlap_radius_cells = 0.0;
  cells_only.overlap_heading_sectors = 0.0;
  // Eq. 8 alone: every cell on the new line is empty, a node each.
  EXPECT_GE(nodesAddedBeside(cells_only, 0.2), 5);
  // With the overlap (the defaults): the nodes 0.5 m away are the same place.
  EXPECT_EQ(nodesAddedBeside(scriptedOptions(), 0.2), 0);
  MapperOptions bad = scriptedOptions();
  bad.overlap_radius_cells = 3.5;  // registrations do not reach that far
  EXPECT_FALSE(bad.validate());
  bad = scriptedOptions();
  bad.overlap_heading_sectors = 1.5;  // more than a sector
  EXPECT_FALSE(bad.validate());
}

// The overlap reaches as far as its radius, past the neighbouring cells: a line 1.6 m beside
// the mapped one (whose nodes are about 2 m apart, to x = 6.3) is 1.6-1.9 m from them up to
// x = 7, outside a one-cell overlap and inside a two-cell one (the cells two away are searched).
TEST(ReducedGraph, AnOverlapWiderThanACellFindsTheNodesTwoCellsAway) {
  MapperOptions one_cell = scriptedOptions();
  one_cell.overlap_radius_cells = 1.0;
  EXPECT_GE(nodesAddedBeside(one_cell, 1.6, 7.0), 3);
  MapperOptions two_cells = scriptedOptions();
  two_cells.overlap_radius_cells = 2.0;
  EXPECT_EQ(nodesAddedBeside(two_cells, 1.6, 7.0), 0);
}

// Two parallel lines 2 m apart (y = 0 and y = 2, facing +x throughout: registrations reach
// 1.5 m, so each line has its own nodes), mapped by a first loop; then `visits` loops that
// cross from the first line to the second at a point that moves 0.7 m each time (x = 0.5 ..
// 6.8 m) and back at x = 8: each crossing closes a loop between nodes of the two lines, and
// the nodes near the crossings are tied to ever other ones. The factors after each loop.
std::vector<int64_t> factorsPerCrossingLoop(ScriptedDrive* drive, int visits) {
  std::vector<int64_t> factors;
  auto loop = [&](double cross_x) {
    drive->driveTo(cross_x, 0.0);
    drive->sidestep(2.0);
    drive->driveTo(8.0, 0.0);
    drive->sidestep(-2.0);
    drive->driveTo(0.0, 0.0);
    factors.push_back(drive->mapper().stats().factors);
  };
  loop(0.0);
  for (int k = 0; k < visits; ++k) loop(0.5 + 0.7 * (k % 10));
  return factors;
}

TEST(ReducedGraph,
     PairsOfNodesTiedToEnoughOthersOpenOnlyWhenInformativeSoFactorsStopGrowingWithVisits) {
  ScriptedDrive unbounded(withPartners(0));
  const std::vector<int64_t> all = factorsPerCrossingLoop(&unbounded, 12);
  ScriptedDrive bounded(withPartners(2));
  const std::vector<int64_t> few = factorsPerCrossingLoop(&bounded, 12);
  const MapperStats& u = unbounded.mapper().stats();
  const MapperStats& b = bounded.mapper().stats();
  // Every visit closes loops; without the bound each new crossing opens pairs (the factors
  // grow with the visits), with it the factors stop once the crossings' nodes are tied.
  EXPECT_EQ(u.closures_saturated, 0);
  EXPECT_GE(all.back(), all[1] + 3);
  EXPECT_GT(b.closures_saturated, 0);
  for (size_t k = 2; k < few.size(); ++k) EXPECT_EQ(few[k], few[1]) << "loop " << k;
  EXPECT_EQ(b.nodes, u.nodes);
  EXPECT_GE(b.loop_closures, 5 * static_cast<int64_t>(few.size() - 1));
  // Every pair opened without the test had a node with fewer partners than the bound.
  EXPECT_LE(b.factors, 2 * b.nodes);
  // Re-localised on the nodes all the same: exact measurements, an exact pose.
  EXPECT_LT(
      (bounded.mapper().pose().mean.translation() - unbounded.mapper().pose().mean.translation())
          .norm(),
      1e-6);
  // A bound far above any node's partners changes nothing.
  ScriptedDrive loose(withPartners(50));
  EXPECT_EQ(factorsPerCrossingLoop(&loose, 12), all);
  MapperOptions bad = scriptedOptions();
  bad.closure_partners = 1;  // every pair tested (a node has its odometry partner)
  EXPECT_FALSE(bad.validate());
  bad = scriptedOptions();
  bad.saturated_closure_information = -1.0;
  EXPECT_FALSE(bad.validate());
}

TEST(ReducedGraph, TheClosureThatTiesANewChainToTheMapOpensWhateverTheBound) {
  // The first line mapped (its inner nodes have two partners: the bound), then a second line
  // in the dark (registrations fail): a chain of new nodes held by odometry alone.
  ScriptedDrive drive(withPartners(2));
  drive.driveTo(8.0, 0.0);
  const auto first_chain_node = static_cast<int64_t>(drive.mapper().nodes().size());
  drive.sidestep(2.0);
  drive.blind(true);
  drive.driveTo(3.5, 0.0);
  const MapperStats dark = drive.mapper().stats();
  ASSERT_GE(dark.nodes, first_chain_node + 3);
  // Back on the first line in the light, among its inner nodes: the closure from the chain's
  // newest node (one partner) ties the chain to the map, whatever the bound says of the
  // map's node.
  drive.blind(false);
  drive.sidestep(-2.0);
  drive.driveTo(2.5, 0.0);
  const MapperStats& after = drive.mapper().stats();
  EXPECT_GT(after.loop_closures, dark.loop_closures);
  int64_t ties = 0;
  for (const auto& [key, pair] : drive.mapper().constraints().pairs())
    ties += key.first < first_chain_node && key.second >= first_chain_node + 1 ? 1 : 0;
  EXPECT_GE(ties, 1);
  EXPECT_EQ(after.closures_saturated, 0);
  // Exact measurements: the chain's nodes, tied, are where the truth is.
  for (int64_t id = first_chain_node; id < static_cast<int64_t>(drive.mapper().nodes().size());
       ++id) {
    const SE3d estimate = drive.mapper().nodePose(0).inverse() * drive.mapper().nodePose(id);
    const SE3d truth = drive.nodeTruth(0).inverse() * drive.nodeTruth(id);
    EXPECT_LT((estimate.translation() - truth.translation()).norm(), 1e-3) << "node " << id;
  }
}

// The first line mapped, the second driven in the dark (a chain on odometry alone, tied to
// the map at both ends), then a crossing from the first line's middle to the chain's middle:
// a pair of nodes with two partners each (the bound), which the map knows only as well as
// the chain's odometry (centimetres), and the registration to a millimetre (σ 1 mm: the
// information of the closure is 5.4 nats). Returns the mapper's counters after it.
MapperStats crossingToADriftedChain(double saturated_information, int64_t* opened) {
  MapperOptions o = withPartners(2);
  o.saturated_closure_information = saturated_information;
  ScriptedDrive drive(o, 1e-6);
  drive.driveTo(8.0, 0.0);
  drive.sidestep(2.0);
  drive.blind(true);
  drive.driveTo(0.0, 0.0);
  drive.blind(false);
  drive.sidestep(-2.0);
  drive.driveTo(4.0, 0.0);
  const int64_t before = drive.mapper().stats().factors;
  drive.sidestep(2.0);
  drive.driveTo(4.5, 0.0);
  *opened = drive.mapper().stats().factors - before;
  return drive.mapper().stats();
}

TEST(ReducedGraph, APairOfSaturatedNodesOpensWhenTheClosureTellsTheMapMuch) {
  int64_t opened = 0;
  const MapperStats informative = crossingToADriftedChain(4.0, &opened);
  EXPECT_GE(opened, 1);
  EXPECT_EQ(informative.closures_saturated, 0);
  const MapperStats never = crossingToADriftedChain(1e3, &opened);
  EXPECT_EQ(opened, 0);
  EXPECT_GE(never.closures_saturated, 1);
}

TEST(ReducedGraph, AMapReloadedFromItsStoreCountsTheSamePartnersAndKeepsItsFactorsBounded) {
  evermap::testing::ScratchDir dir;
  ScriptedDrive drive(withPartners(2));
  factorsPerCrossingLoop(&drive, 4);
  auto store = MapStore::open(dir.path() / "map.db");
  ASSERT_TRUE(store) << store.error().message;
  ASSERT_TRUE(store->save(drive.mapper(), drive.mapper().session(), 0));
  auto snap = store->load();
  ASSERT_TRUE(snap) << snap.error().message;
  // Replayed (folded rows included) into the same pairs: the same partners for every node.
  Mapper reloaded(withPartners(2));
  ASSERT_TRUE(reloaded.restore(*snap));
  ASSERT_EQ(reloaded.nodes().size(), drive.mapper().nodes().size());
  for (int64_t id = 0; id < static_cast<int64_t>(reloaded.nodes().size()); ++id)
    EXPECT_EQ(reloaded.constraints().partners(id), drive.mapper().constraints().partners(id))
        << "node " << id;
  EXPECT_EQ(reloaded.stats().factors, drive.mapper().stats().factors);
  // The restarted mapper goes on with the bound where the first left off.
  const int64_t factors_before = drive.mapper().stats().factors;
  ASSERT_TRUE(drive.restart(*snap, withPartners(2), 0.5));
  const std::vector<int64_t> after = factorsPerCrossingLoop(&drive, 8);
  EXPECT_GT(drive.mapper().stats().closures_saturated, 0);
  EXPECT_EQ(after.back(), factors_before);
}

TEST(ReducedGraph, AnElevatorRideMovesTheEstimateToTheNewFloorAndTakesNoStepInTheCab) {
  // elevator-proc announces no floor before the first ride: its start names the height of
  // the floor left. Keyframes in the cab take no step (the cab is a place that moves), and
  // the ride's end moves the estimate to the new floor's height.
  Mapper m(scriptedOptions());
  ASSERT_TRUE(m.onVo(voRestart(0)));
  ASSERT_EQ(m.nodes().size(), 1u);
  ASSERT_TRUE(m.onFloor(floorMsg(1'000'000, floor_t::EVENT_RIDE_START, 0.0, -1)));
  const int64_t steps = m.stats().steps;
  for (int k = 1; k <= 5; ++k)
    ASSERT_TRUE(m.onVo(voMsg(1'000'000 + k * 600'000, k == 1 ? 0 : 1'000'000 + (k - 1) * 600'000,
                             SE3d(), 1e-3, true)));
  EXPECT_EQ(m.stats().steps, steps);
  floor_t end = floorMsg(5'000'000, floor_t::EVENT_RIDE_END, -4.7, 1);
  end.new_floor = 1;
  ASSERT_TRUE(m.onFloor(end));
  EXPECT_NEAR(m.pose().mean.translation().z(), -4.7, 1e-6);
  EXPECT_EQ(m.floor(), 1);
  ASSERT_EQ(m.floors().size(), 2u);
  EXPECT_EQ(m.floors().at(0), 0.0);
  EXPECT_EQ(m.floors().at(1), -4.7);
}

TEST(ReducedGraph, ARideEndsOnTheMapsFloorAtItsHeightWhateverElevatorProcCallsIt) {
  // A map with floors 0 (0 m) and 1 (-4.7 m). A new session's elevator-proc starts its own
  // table on floor 0 and calls the first floor it rides to "floor 1" wherever it is: up at
  // +4.7 m that is a floor the map does not have (a new label, 2); down at -4.6 m it is the
  // map's floor 1.
  for (const double ride_m : {4.7, -4.6}) {
    Mapper m(scriptedOptions());
    ASSERT_TRUE(m.onVo(voRestart(0)));
    ASSERT_TRUE(m.onFloor(floorMsg(1'000'000, floor_t::EVENT_RIDE_START, 0.0, -1)));
    ASSERT_TRUE(m.onFloor(floorMsg(5'000'000, floor_t::EVENT_RIDE_END, -4.7, 1)));
    ASSERT_EQ(m.floor(), 1);
    // Back to floor 0, then the new session's ride, labelled 1 by its elevator-proc.
    ASSERT_TRUE(m.onFloor(floorMsg(6'000'000, floor_t::EVENT_RIDE_START, -4.7, -1)));
    ASSERT_TRUE(m.onFloor(floorMsg(9'000'000, floor_t::EVENT_RIDE_END, 0.05, 0)));
    ASSERT_EQ(m.floor(), 0);
    ASSERT_TRUE(m.onFloor(floorMsg(10'000'000, floor_t::EVENT_RIDE_START, 0.0, -1)));
    floor_t end = floorMsg(14'000'000, floor_t::EVENT_RIDE_END, ride_m, 1);
    end.new_floor = 1;
    ASSERT_TRUE(m.onFloor(end));
    EXPECT_EQ(m.floor(), ride_m > 0 ? 2 : 1) << ride_m;
  }
}

TEST(FullGraph, AddsANodeAtEveryStepThroughTheSameCode) {
  MapperOptions o = scriptedOptions();
  o.full_graph = true;
  ScriptedDrive drive(o);
  lap(drive);
  const int64_t first = drive.mapper().stats().nodes;
  lap(drive);
  EXPECT_EQ(drive.mapper().stats().nodes, drive.mapper().stats().steps);
  EXPECT_GT(drive.mapper().stats().nodes, first + 10);
}

TEST(ReducedGraph, ActiveNodeRegistrationReplacesDeltaOnlyWhenItIsMoreCertain) {
  // The paper's entropy test instead of the fusion.
  MapperOptions o = scriptedOptions();
  o.fuse_active_registration = false;
  // Registrations far more certain than VO (variance 1e-12 against 1e-6 per frame): every
  // registration to the active node wins the det(Σ) test.
  ScriptedDrive sharp(o, 1e-12);
  lap(sharp);
  const auto& a = sharp.mapper().stats();
  EXPECT_GT(a.delta_replaced, 10);
  EXPECT_EQ(a.delta_fused, 0);
  // Registrations far less certain (variance 1): Δ is kept, except for the one forced
  // re-localisation after each loop closure.
  ScriptedDrive blurred(o, 1.0);
  lap(blurred);
  const auto& b = blurred.mapper().stats();
  EXPECT_GT(b.delta_kept, 10);
  EXPECT_LE(b.delta_replaced, b.loop_closures);
}

TEST(ReducedGraph, RecoversWhenTwoRegistrationsAgreeAgainstAWrongDelta) {
  // A mapped corridor, then an unseen 0.6 m slip: Δ (confident, wrong) contradicts every
  // registration. The first is rejected as a possible false match; the second agrees with it
  // through odometry, so Δ is what was wrong. Without that the mapper would reject every
  // later registration and add nodes over the mapped corridor.
  ScriptedDrive drive(scriptedOptions(), 1e-6);
  lap(drive);
  drive.driveTo(3.0, 0.0);
  const size_t nodes_before = drive.mapper().nodes().size();
  drive.slip(0.6);
  drive.driveTo(8.0, 0.0);
  drive.driveTo(8.0, std::numbers::pi);
  drive.driveTo(0.0, std::numbers::pi);
  const auto& s = drive.mapper().stats();
  EXPECT_GE(s.rejected_map_gate, 1);
  EXPECT_GE(s.gate_recoveries, 1);
  EXPECT_LE(drive.mapper().nodes().size(), nodes_before + 1);
  // The map's origin is the first frame, 0.1 m along x.
  const SE3d estimate = drive.mapper().pose().mean;
  EXPECT_LT((estimate.translation() - (drive.truePose().translation() - Vec3(0.1, 0, 0))).norm(),
            0.05);
}

TEST(ReducedGraph, RegistrationsThatAgreeOnAPlaceOneTexturePeriodAwayDoNotMoveTheRobot) {
  // A floor pattern that repeats every 12 m: on a mapped 16 m corridor, every registration of
  // the robot's first 4 m places it 12 m further on, and they agree with each other through
  // odometry. The gate rejects them; a recovery would jump the robot 12 m, far more than
  // odometry can have drifted in 4 m since the last confirmed registration.
  for (const bool bounded : {true, false}) {
    MapperOptions o = scriptedOptions();
    if (!bounded) o.recovery_slack_m = 1e9;  // the recovery without the drift bound
    ScriptedDrive drive(o, 1e-6);
    drive.driveTo(16.0, 0.0);
    drive.driveTo(16.0, std::numbers::pi);
    drive.driveTo(0.0, std::numbers::pi);
    drive.driveTo(0.0, 0.0);
    drive.aliasBy(12.0);
    drive.driveTo(4.0, 0.0);
    const auto& s = drive.mapper().stats();
    const SE3d estimate = drive.mapper().pose().mean;
    const double error_m =
        (estimate.translation() - (drive.truePose().translation() - Vec3(0.1, 0, 0))).norm();
    if (bounded) {
      EXPECT_GE(s.rejected_map_gate, 2);
      EXPECT_GE(s.recoveries_too_far, 1);
      EXPECT_EQ(s.gate_recoveries, 0);
      EXPECT_LT(error_m, 0.05);
    } else {
      EXPECT_GE(s.gate_recoveries, 1);
      EXPECT_GT(error_m, 10.0);  // what the bound prevents
    }
  }
}

TEST(ReducedGraph, AGateRecoveryToAnotherNodeAddsNoClosureFromTheWrongDelta) {
  // A 2 m slip VO does not see: the active node's cell has nothing to register to, the global
  // search finds the node 2 m on. The map gate rejects a_T_b (Δ says 0 m, the map 2 m), and the
  // second registration agrees with the first: the recovery. A closure a → b from Δ would pull
  // the corridor 2 m together; the robot is placed at b instead.
  ScriptedDrive drive(scriptedOptions(), 1e-6);
  lap(drive);
  drive.driveTo(3.0, 0.0);
  drive.slip(2.0);
  drive.driveTo(8.0, 0.0);
  EXPECT_GE(drive.mapper().stats().gate_recoveries, 1);
  for (const auto& c : drive.mapper().constraints().all()) {
    if (!c.accepted || c.kind != ConstraintKind::kLoop) continue;
    const SE3d truth = drive.nodeTruth(c.from).inverse() * drive.nodeTruth(c.to);
    EXPECT_LT((c.from_T_to.mean.translation() - truth.translation()).norm(), 0.05)
        << c.from << " -> " << c.to;
  }
  const SE3d estimate = drive.mapper().pose().mean;
  EXPECT_LT((estimate.translation() - (drive.truePose().translation() - Vec3(0.1, 0, 0))).norm(),
            0.05);
}

TEST(ReducedGraph, ActiveNodeRegistrationIsFusedWithDeltaExceptToReLocalise) {
  MapperOptions o = scriptedOptions();
  o.fuse_active_registration = true;
  for (const double variance : {1e-12, 1e-4, 1.0}) {
    ScriptedDrive drive(o, variance);
    lap(drive);
    lap(drive);
    const auto& s = drive.mapper().stats();
    EXPECT_GT(s.delta_fused, 10) << variance;
    EXPECT_EQ(s.delta_kept, 0) << variance;
    // Replaced only by the re-localisation that follows a loop closure.
    EXPECT_LE(s.delta_replaced, s.loop_closures) << variance;
    // Exact measurements fused stay exact, whatever their weights.
    const SE3d end = drive.mapper().pose().mean;
    EXPECT_LT((end.translation() - Vec3(-0.1, 0, 0)).norm(), 1e-6) << variance;
    EXPECT_LT(core::rotationAngle(end.so3()), 1e-6) << variance;
  }
}

TEST(ReducedGraph, NodesOfAFloorAreHeldAtTheFloorsFirstHeightNotAtEachRidesEstimate) {
  ScriptedDrive drive(scriptedOptions());
  lap(drive);
  // Back on floor 0 from a ride whose estimate is 0.5 m off, with σ = 1 m.
  drive.rideEnd(0, 0.5, 1.0);
  const size_t before = drive.mapper().nodes().size();
  drive.driveTo(20.0, 0.0);
  ASSERT_GT(drive.mapper().nodes().size(), before + 5);
  EXPECT_EQ(drive.mapper().floors().at(0), 0.0);
  for (size_t id = before; id < drive.mapper().nodes().size(); ++id)
    EXPECT_LT(std::abs(drive.mapper().nodePose(static_cast<int64_t>(id)).translation().z()), 0.01)
        << id;
}

TEST(Mapper, ALongGapInVoStartsOneSessionEvenWhenItsFloorMessageIsLost) {
  for (const bool announce : {true, false}) {
    ScriptedDrive drive(scriptedOptions());
    lap(drive);
    ASSERT_EQ(drive.mapper().session(), 0);
    const int64_t nodes = drive.mapper().stats().nodes;
    drive.newSession(3600.0, announce);
    EXPECT_EQ(drive.mapper().session(), 1) << "FLOOR sent: " << announce;
    EXPECT_TRUE(drive.mapper().lost());
    lap(drive);
    // Re-localised by global registrations, the second session maps nothing new.
    EXPECT_FALSE(drive.mapper().lost()) << "FLOOR sent: " << announce;
    EXPECT_EQ(drive.mapper().session(), 1);
    EXPECT_EQ(drive.mapper().stats().nodes, nodes);
  }
}

// A session starts where the map has a place, but the global search finds it (by
// appearance) only once, in the first seconds: the candidate placement is checked by a
// node-mode request where it says the robot is, and the session is placed on the map;
// waiting for a second global match, it stays lost.
TEST(Mapper, ALostRobotChecksItsCandidatePlacementAgainstTheNodeWhereItPredictsItIs) {
  for (const int checks : {2, 0}) {
    MapperOptions o = scriptedOptions();
    o.relocalization_checks = checks;
    ScriptedDrive drive(o);
    lap(drive);
    const int64_t nodes = drive.mapper().stats().nodes;
    drive.globalSearchesFind(1);
    drive.newSession(3600.0, true);
    lap(drive);
    if (checks > 0) {
      EXPECT_FALSE(drive.mapper().lost());
      EXPECT_EQ(drive.mapper().stats().relocalizations, 1);
      // Placed on the lap it mapped: not a second copy of it (a step whose cell is empty
      // may still add one, its global search finding nothing).
      EXPECT_LE(drive.mapper().stats().nodes, nodes + 2);
    } else {
      EXPECT_TRUE(drive.mapper().lost());
      EXPECT_EQ(drive.mapper().stats().relocalizations, 0);
    }
  }
}

// The check that needs no motion: the candidate's own keyframe registered against a node the
// map links to the candidate's node. A session that starts on a mapped place is placed at its
// first keyframe, before it moves (the checks at later keyframes came too late live: a robot
// starting slowly makes its next keyframe seconds later, past the place).
TEST(Mapper, ALostRobotChecksItsCandidateOnTheSameKeyframeAgainstALinkedNode) {
  ScriptedDrive drive(scriptedOptions());
  lap(drive);
  // Between nodes 0 (x = 0.1 m) and 1 (1.6 m): the oracle registers to either (< 1.5 m).
  drive.driveTo(0.8, 0.0);
  drive.newSession(3600.0, true);
  EXPECT_FALSE(drive.mapper().lost());
  EXPECT_EQ(drive.mapper().stats().relocalizations, 1);
  EXPECT_EQ(drive.mapper().stats().relocalization_same_frame_checks, 1);
  EXPECT_EQ(drive.mapper().stats().relocalization_disagreements, 0);
  // Placed where it is: the next lap adds no copy of the corridor.
  const int64_t nodes = drive.mapper().stats().nodes;
  lap(drive);
  EXPECT_LE(drive.mapper().stats().nodes, nodes + 2);
}

TEST(Mapper, DropsMalformedAndStaleMessagesAndCountsThem) {
  Mapper m(scriptedOptions());
  register_result_t stale{};
  stale.request_id = 42;
  EXPECT_FALSE(m.onRegisterResult(stale));
  attitude_t a{};
  a.utime = 10;
  a.roll_rad = std::nan("");
  EXPECT_FALSE(m.onAttitude(a));
  floor_t f{};
  f.height_m = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(m.onFloor(f));
  EXPECT_EQ(m.stats().dropped, 3);
  EXPECT_EQ(m.stats().nodes, 0);
}

sim::SimOptions shortPatrol() { return sim::testing::smallPatrol(7, 1, 0.05, 1, 1); }

TEST(ReducedGraph, HasFarFewerNodesThanTheFullGraphWithComparableAccuracy) {
  MapperOptions reduced_options;
  MapperOptions full_options;
  full_options.full_graph = true;
  evermap::testing::ScratchDir dir;
  auto reduced = runOffline(shortPatrol(), reduced_options, dir.path() / "map.db");
  auto full = runOffline(shortPatrol(), full_options);
  ASSERT_TRUE(reduced) << reduced.error().message;
  ASSERT_TRUE(full) << full.error().message;
  EXPECT_EQ(reduced->step_poses, full->step_poses);
  EXPECT_LT(reduced->nodes * 5, full->nodes);
  EXPECT_GT(reduced->stats.loop_closures, 10);
  EXPECT_EQ(reduced->decode_errors, 0);
  EXPECT_EQ(reduced->stats.dropped, 0);
  // Comparable accuracy: a few decimetres over ~300 m, and within 2.5x of the full graph.
  EXPECT_LT(reduced->ate_rmse_m, 0.5);
  EXPECT_LT(full->ate_rmse_m, 0.5);
  EXPECT_LT(reduced->ate_rmse_m, 2.5 * full->ate_rmse_m);
  // The map store holds the final map: every node, and every constraint (some folded).
  auto store = MapStore::open(dir.path() / "map.db");
  ASSERT_TRUE(store);
  auto snap = store->load();
  ASSERT_TRUE(snap);
  EXPECT_EQ(static_cast<int64_t>(snap->nodes.size()), reduced->nodes);
  EXPECT_EQ(snap->constraintsRepresented(), reduced->constraints);
  EXPECT_GT(reduced->store_transactions, reduced->nodes);
}

TEST(ViewCover, APoseIsANewViewUnlessAnEarlierOneIsWithinTheReachOnItsFloor) {
  ViewCover cover(1.0, std::numbers::pi / 4);
  auto at = [](double x, double y, double yaw) {
    return core::SE3d(Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ())),
                      core::Vec3(x, y, 0.0));
  };
  EXPECT_TRUE(cover.add(0, at(0.0, 0.0, 0.0)));
  EXPECT_FALSE(cover.add(0, at(0.9, 0.0, 0.7)));                         // within 1 m and 45°
  EXPECT_FALSE(cover.add(0, at(-0.5, -0.6, -0.7)));                      // across a cell corner
  EXPECT_TRUE(cover.add(0, at(1.1, 0.0, 0.0)));                          // beyond the radius
  EXPECT_TRUE(cover.add(0, at(0.0, 0.0, 0.9)));                          // beyond the heading
  EXPECT_TRUE(cover.add(1, at(0.0, 0.0, 0.0)));                          // another floor
  EXPECT_FALSE(cover.add(0, at(0.0, 0.0, 2 * std::numbers::pi - 0.1)));  // the heading wraps
  EXPECT_EQ(cover.views(), 4);
}

// The counters are listed once (MapperStats::counters()): text() prints each of them once,
// with its value, and addCounters sums each of them.
TEST(MapperStats, TextPrintsEveryCounterOnceAndAddCountersSumsEveryCounter) {
  MapperStats a;
  int64_t v = 1;
  for (const MapperStats::Counter& c : MapperStats::counters()) a.*c.field = v++;
  MapperStats sum = a;
  sum.addCounters(a);
  std::istringstream text(a.text());
  std::set<std::string> names;
  std::string name;
  int64_t value = 0;
  size_t k = 0;
  while (text >> name >> value) {
    ASSERT_LT(k, MapperStats::counters().size());
    EXPECT_EQ(name, MapperStats::counters()[k].name);
    EXPECT_EQ(value, static_cast<int64_t>(k + 1));
    EXPECT_EQ(sum.*MapperStats::counters()[k].field, 2 * value) << name;
    names.insert(name);
    ++k;
  }
  EXPECT_EQ(k, MapperStats::counters().size());
  EXPECT_EQ(names.size(), k);
}

}  // namespace
}  // namespace evermap::mapper
