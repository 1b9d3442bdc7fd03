// mapper-proc: the warm restart (MapperOptions::warm_restart_*, docs/mapper.md "Restarts").
// A mapper killed and restarted from its store resumes tracking from the saved state when
// the gap is short, starts lost when it is not, and never closes a loop from the pose it
// held across the gap.

#include <gtest/gtest.h>

#include <csignal>
#include <sys/wait.h>
#include <unistd.h>

#include <random>

#include "mapper-proc/map_store.h"
#include "mapper-proc/mapper.h"
#include "tests/scratch_dir.h"
#include "tests/scripted_drive.h"

namespace evermap::mapper {
namespace {

using namespace testing;  // tests/mapper_messages.h, tests/scripted_drive.h

// Drives the corridor out to x = 8 m, saves the map with the tracking state, and returns
// what a restarted mapper-proc would load.
MapSnapshot drivenAndSaved(ScriptedDrive& drive, const std::filesystem::path& file) {
  drive.driveTo(8.0, 0.0);
  auto store = MapStore::open(file);
  EXPECT_TRUE(store) << store.error().message;
  EXPECT_TRUE(store->save(drive.mapper(), drive.mapper().session(), 0));
  auto snap = store->load();
  EXPECT_TRUE(snap) << snap.error().message;
  EXPECT_TRUE(snap->tracking);
  return *snap;
}

// Every accepted loop closure against the truth at its nodes: how many are more than 0.3 m or
// 3° off (what evermap-pipeline-eval counts as false, with a tighter bound).
// Back home facing the other way (new places), then out again along the mapped corridor,
// where registrations to the restored map can place the robot.
void homeAndOutAlongTheMappedCorridor(ScriptedDrive& drive) {
  drive.driveTo(14.0, M_PI);
  drive.driveTo(0.0, M_PI);
  drive.driveTo(0.0, 0.0);
  drive.driveTo(8.0, 0.0);
}

int falseLoops(ScriptedDrive& drive) {
  int n = 0;
  for (const Constraint& c : drive.mapper().constraints().all()) {
    if (c.kind != ConstraintKind::kLoop || !c.accepted) continue;
    const SE3d truth = drive.nodeTruth(c.from).inverse() * drive.nodeTruth(c.to);
    const SE3d err = truth.inverse() * c.from_T_to.mean;
    if (err.translation().norm() > 0.3 || core::rotationAngle(err.so3()) > 3.0 * M_PI / 180.0) ++n;
  }
  return n;
}

TEST(MapperWarmRestart, ARestartWithinTheGapResumesTrackingAndAddsNodesAtOnceWithoutRelocalising) {
  evermap::testing::ScratchDir dir;
  ScriptedDrive drive(scriptedOptions());
  const MapSnapshot map = drivenAndSaved(drive, dir.path() / "map.db");
  const auto restored = static_cast<int64_t>(map.nodes.size());
  // Half a second of message time lost (mapper-proc restarts in 0.3 s at 1x), and a dark
  // stretch after it: no registration can place the robot, as in an unmapped place.
  drive.blind(true);
  ASSERT_TRUE(drive.restart(map, scriptedOptions(), 0.5));
  EXPECT_EQ(drive.mapper().stats().warm_restarts, 1);
  EXPECT_FALSE(drive.mapper().lost());
  EXPECT_TRUE(drive.mapper().resumedUnconfirmed());
  EXPECT_EQ(drive.mapper().session(), map.tracking->session);  // the same drive, the same session
  const int64_t restart_utime = drive.utime();
  drive.driveTo(14.0, 0.0);
  const Mapper& m = drive.mapper();
  EXPECT_EQ(m.stats().relocalizations, 0);
  // A node about every metre of the new 6 m, the first one at once.
  ASSERT_GE(static_cast<int64_t>(m.nodes().size()), restored + 5);
  const int64_t first_new = restored;
  // The first at the restart's first keyframe (1.3 m past the saved node, a new place).
  EXPECT_EQ(m.nodes()[static_cast<size_t>(first_new)].keyframe_utime, restart_utime);
  // Nothing moved during the gap: the nodes are where they are (the gap's covariance is a
  // bound, not an error). Relative to node 0 (the drive's truth starts 0.1 m ahead).
  for (int64_t id = first_new; id < static_cast<int64_t>(m.nodes().size()); ++id) {
    const SE3d estimate = m.nodePose(0).inverse() * m.nodePose(id);
    const SE3d truth = drive.nodeTruth(0).inverse() * drive.nodeTruth(id);
    EXPECT_LT((estimate.translation() - truth.translation()).norm(), 0.05) << "node " << id;
  }
  // The first new node hangs on the saved node by the gap's covariance: 0.75 m in x and y.
  const auto pair = m.constraints().pairs().find({map.tracking->active_node, first_new});
  ASSERT_NE(pair, m.constraints().pairs().end());
  EXPECT_GT(pair->second.i_T_j.covariance(0, 0), 0.5 * 0.5);

  // Back into the light, home (the way back faces the other way: new places) and out again
  // along the mapped corridor: two registrations to the restored map confirm the placement;
  // no loop closure is false.
  drive.blind(false);
  homeAndOutAlongTheMappedCorridor(drive);
  EXPECT_GE(m.stats().warm_confirmations, 1);
  EXPECT_FALSE(m.resumedUnconfirmed());
  EXPECT_GT(m.stats().loop_closures, 3);
  EXPECT_EQ(falseLoops(drive), 0);
}

// Six seconds lost (a 20x replay's restart): the held pose is 9 m uncertain, too much to
// choose a node's cell; nodes wait for the placement, which the first mapped place confirms.
TEST(MapperWarmRestart, APoseTooUncertainForANodesCellWaitsForTheConfirmation) {
  evermap::testing::ScratchDir dir;
  ScriptedDrive drive(scriptedOptions());
  const MapSnapshot map = drivenAndSaved(drive, dir.path() / "map.db");
  drive.blind(true);
  ASSERT_TRUE(drive.restart(map, scriptedOptions(), 6.0));
  const Mapper& m = drive.mapper();
  EXPECT_EQ(m.stats().warm_restarts, 1);
  drive.driveTo(14.0, 0.0);
  EXPECT_EQ(m.nodes().size(), map.nodes.size());
  EXPECT_TRUE(m.resumedUnconfirmed());
  drive.blind(false);
  drive.driveTo(14.0, M_PI);
  drive.driveTo(0.0, M_PI);  // facing the other way: nothing to register against
  EXPECT_EQ(m.nodes().size(), map.nodes.size());
  drive.driveTo(0.0, 0.0);
  drive.driveTo(8.0, 0.0);
  EXPECT_GE(m.stats().warm_confirmations, 1);
  EXPECT_EQ(m.stats().relocalizations, 0);
  EXPECT_FALSE(m.resumedUnconfirmed());
  EXPECT_EQ(falseLoops(drive), 0);
  drive.driveTo(8.0, M_PI);
  drive.driveTo(0.0, M_PI);  // now placed: the way back is mapped
  EXPECT_GT(m.nodes().size(), map.nodes.size() + 3);
}

TEST(MapperWarmRestart, ARestartBeyondTheGapStartsLost) {
  evermap::testing::ScratchDir dir;
  ScriptedDrive drive(scriptedOptions());
  const MapSnapshot map = drivenAndSaved(drive, dir.path() / "map.db");
  drive.blind(true);
  ASSERT_TRUE(drive.restart(map, scriptedOptions(), 20.0));  // > warm_restart_max_gap_s = 10
  const Mapper& m = drive.mapper();
  EXPECT_EQ(m.stats().warm_restarts, 0);
  EXPECT_EQ(m.stats().lost_restarts, 1);
  EXPECT_TRUE(m.lost());
  drive.driveTo(14.0, 0.0);
  EXPECT_EQ(m.nodes().size(), map.nodes.size());  // lost: no node until re-localised
  drive.blind(false);
  homeAndOutAlongTheMappedCorridor(drive);
  EXPECT_GE(m.stats().relocalizations, 1);
}

TEST(MapperWarmRestart, WithTheWarmRestartOffEveryRestartStartsLost) {
  evermap::testing::ScratchDir dir;
  ScriptedDrive drive(scriptedOptions());
  const MapSnapshot map = drivenAndSaved(drive, dir.path() / "map.db");
  MapperOptions off = scriptedOptions();
  off.warm_restart_max_gap_s = 0.0;
  ASSERT_TRUE(drive.restart(map, off, 0.5));
  EXPECT_TRUE(drive.mapper().lost());
  EXPECT_EQ(drive.mapper().stats().lost_restarts, 1);
}

// The robot drove 3 m during a 4 s gap, along the mapped corridor: the held pose is 3 m
// behind it (σ 6 m). The registrations that find the mapped places must neither close a loop from it
// nor leave the robot where it was: the earlier attempt at this closed loops from the held
// pose (6 false loop edges in the live run, pose ATE 3.3 m).
TEST(MapperWarmRestart, MotionDuringTheGapMakesNoFalseClosureAndTheRobotIsPlacedWhereItIs) {
  evermap::testing::ScratchDir dir;
  ScriptedDrive drive(scriptedOptions());
  lap(drive);
  drive.driveTo(3.0, 0.0);  // the second time out, over mapped places
  auto store = MapStore::open(dir.path() / "map.db");
  ASSERT_TRUE(store);
  ASSERT_TRUE(store->save(drive.mapper(), drive.mapper().session(), 0));
  auto map = store->load();
  ASSERT_TRUE(map && map->tracking);
  ASSERT_TRUE(drive.restart(*map, scriptedOptions(), 4.0, 3.0));  // now at x = 6
  EXPECT_EQ(drive.mapper().stats().warm_restarts, 1);
  drive.driveTo(8.0, 0.0);
  const Mapper& m = drive.mapper();
  EXPECT_GE(m.stats().warm_confirmations, 1);
  EXPECT_EQ(falseLoops(drive), 0);
  // Placed: the estimate is the truth, and no node was added over the mapped corridor.
  const SE3d estimate = m.nodePose(0).inverse() * m.pose().mean;
  const SE3d truth = drive.nodeTruth(0).inverse() * drive.truePose();
  EXPECT_LT((estimate.translation() - truth.translation()).norm(), 0.05);
  EXPECT_LE(m.nodes().size(), map->nodes.size() + 1);
}

// The tracking state is written in the transaction of the map it refers to, and alone between
// them: a process killed at any moment leaves a store that opens, passes the integrity check
// and holds either no state or one that names a stored node and is not older than it.
TEST(MapStore, TheTrackingStateSurvivesAKillMidSave) {
  evermap::testing::ScratchDir dir;
  std::mt19937 rng(17);
  int with_state = 0;
  for (int kill = 0; kill < 12; ++kill) {
    const auto file = dir.path() / ("map" + std::to_string(kill) + ".db");
    const pid_t child = fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
      // The child saves as mapper-proc does, forever: the map after each leg, the tracking
      // state after every frame. (No thread exists before the fork.)
      ScriptedDrive drive(scriptedOptions());
      auto store = MapStore::open(file);
      if (!store) _exit(2);
      for (int leg = 0;; ++leg) {
        const double from = leg % 2 == 0 ? 0.0 : 8.0, yaw = leg % 2 == 0 ? 0.0 : M_PI;
        drive.driveTo(from, yaw);
        for (int k = 1; k <= 5; ++k) {
          drive.driveTo(from + (8.0 - 2.0 * from) * k / 5.0, yaw);
          if (!store->save(drive.mapper(), drive.mapper().session(), 0)) _exit(3);
          (void)store->saveTracking(drive.mapper());
        }
      }
    }
    usleep(20000 + static_cast<useconds_t>(std::uniform_int_distribution<int>(0, 250000)(rng)));
    ASSERT_EQ(::kill(child, SIGKILL), 0);
    int status = 0;
    ASSERT_EQ(waitpid(child, &status, 0), child);
    ASSERT_TRUE(WIFSIGNALED(status)) << "the child ended by itself: " << status;
    if (!std::filesystem::exists(file)) continue;
    auto store = MapStore::open(file);
    ASSERT_TRUE(store) << store.error().message;
    ASSERT_TRUE(store->integrityCheck());
    auto snap = store->load();
    ASSERT_TRUE(snap) << snap.error().message;
    if (snap->tracking) {
      ++with_state;
      ASSERT_GE(snap->tracking->active_node, 0);
      ASSERT_LT(snap->tracking->active_node, static_cast<int64_t>(snap->nodes.size()));
      for (const StoredNode& n : snap->nodes) EXPECT_LE(n.node.keyframe_utime, snap->tracking->utime);
      Mapper m{scriptedOptions()};
      ASSERT_TRUE(m.restore(*snap));
      EXPECT_EQ(m.stats().lost_restarts, 0);  // usable: decided at the first VO
    }
  }
  EXPECT_GE(with_state, 3);
}

// Stores written before the tracking state (schema version 0: no map_tracking) open, read
// only and read-write; read-write migrates them; a restart from one starts lost, as before.
TEST(MapStore, AStoreOfTheSchemaBeforeTheTrackingStateOpensAndIsMigrated) {
  evermap::testing::ScratchDir dir;
  const auto file = dir.path() / "old.db";
  ScriptedDrive drive(scriptedOptions());
  drive.driveTo(4.0, 0.0);
  {
    auto store = MapStore::open(file);
    ASSERT_TRUE(store && store->save(drive.mapper(), 0, 0));
  }
  {
    // Back to what the code before this schema wrote: no map_tracking, user_version 0.
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(file.c_str(), &db), SQLITE_OK);
    ASSERT_EQ(sqlite3_exec(db, "DROP TABLE map_tracking; PRAGMA user_version=0;", nullptr, nullptr, nullptr), SQLITE_OK);
    sqlite3_close(db);
  }
  {
    auto ro = MapStore::open(file, MapStoreOptions{2, true});
    ASSERT_TRUE(ro) << ro.error().message;
    auto snap = ro->load();
    ASSERT_TRUE(snap) << snap.error().message;
    EXPECT_FALSE(snap->tracking);
    EXPECT_EQ(snap->nodes.size(), drive.mapper().nodes().size());
  }
  auto store = MapStore::open(file);
  ASSERT_TRUE(store) << store.error().message;
  EXPECT_EQ(*store->schemaVersion(), 1);
  auto snap = store->load();
  ASSERT_TRUE(snap);
  EXPECT_FALSE(snap->tracking);
  Mapper m{scriptedOptions()};
  ASSERT_TRUE(m.restore(*snap));
  EXPECT_EQ(m.stats().lost_restarts, 1);
  EXPECT_TRUE(m.lost());
  ASSERT_TRUE(store->save(drive.mapper(), 0, 0));
  EXPECT_TRUE(store->load()->tracking);
  EXPECT_TRUE(store->integrityCheck());
}

TEST(MapStore, AStoreOfANewerSchemaIsRefused) {
  evermap::testing::ScratchDir dir;
  const auto file = dir.path() / "new.db";
  {
    auto store = MapStore::open(file);
    ASSERT_TRUE(store);
  }
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(file.c_str(), &db), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(db, "PRAGMA user_version=7;", nullptr, nullptr, nullptr), SQLITE_OK);
  sqlite3_close(db);
  auto store = MapStore::open(file);
  ASSERT_FALSE(store);
  EXPECT_NE(store.error().message.find("version 7"), std::string::npos) << store.error().message;
}

}  // namespace
}  // namespace evermap::mapper
