// mapper-proc's map store: the tracking state survives a kill mid-save, and stores of older
// schemas open and are migrated (docs/map-store.md).

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
      for (const StoredNode& n : snap->nodes)
        EXPECT_LE(n.node.keyframe_utime, snap->tracking->utime);
      Mapper m{scriptedOptions()};
      ASSERT_TRUE(m.restore(*snap));
      EXPECT_EQ(m.stats().lost_restarts, 0);  // usable: decided at the first VO
    }
  }
  EXPECT_GE(with_state, 3);
}

// The drive's map saved at `file`, then rewritten by `sql` into what older code wrote.
void saveAsAnOlderSchema(ScriptedDrive& drive, const std::filesystem::path& file, const char* sql) {
  {
    auto store = MapStore::open(file);
    ASSERT_TRUE(store && store->save(drive.mapper(), 0, 0));
  }
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(file.c_str(), &db), SQLITE_OK);
  const int rc = sqlite3_exec(db, sql, nullptr, nullptr, nullptr);
  const std::string error = sqlite3_errmsg(db);
  sqlite3_close(db);
  ASSERT_EQ(rc, SQLITE_OK) << error;
}

// The store at `file` opened read-only, as it is: its map into *snap.
void loadReadOnly(const std::filesystem::path& file, MapSnapshot* snap) {
  auto ro = MapStore::open(file, MapStoreOptions{2, true});
  ASSERT_TRUE(ro) << ro.error().message;
  auto loaded = ro->load();
  ASSERT_TRUE(loaded) << loaded.error().message;
  *snap = std::move(*loaded);
}

// Stores written before the tracking state (schema version 0: no map_tracking) open, read
// only and read-write; read-write migrates them; a restart from one starts lost, as before.
TEST(MapStore, AStoreOfTheSchemaBeforeTheTrackingStateOpensAndIsMigrated) {
  evermap::testing::ScratchDir dir;
  const auto file = dir.path() / "old.db";
  ScriptedDrive drive(scriptedOptions());
  drive.driveTo(4.0, 0.0);
  // Back to what the code before this schema wrote: no map_tracking, user_version 0.
  ASSERT_NO_FATAL_FAILURE(
      saveAsAnOlderSchema(drive, file, "DROP TABLE map_tracking; PRAGMA user_version=0;"));
  {
    MapSnapshot snap;
    ASSERT_NO_FATAL_FAILURE(loadReadOnly(file, &snap));
    EXPECT_FALSE(snap.tracking);
    EXPECT_EQ(snap.nodes.size(), drive.mapper().nodes().size());
  }
  auto store = MapStore::open(file);
  ASSERT_TRUE(store) << store.error().message;
  EXPECT_EQ(*store->schemaVersion(), map::kSchemaVersion);
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

// Stores of schema version 1 (map_tracking without its odom_* columns) open read-only as they
// are and read-write migrated to the current version; their state restarts warm without the bridge,
// and the next save stores the odometry pose, which a load gives back as it was saved.
TEST(MapStore, AStoreOfTheSchemaBeforeTheOdometryPoseIsMigratedAndTheRoundTripKeepsThePose) {
  evermap::testing::ScratchDir dir;
  const auto file = dir.path() / "v1.db";
  ScriptedDrive drive(scriptedOptions());
  drive.driveTo(4.0, 0.0);
  // Back to what version 1 wrote: map_tracking with its first nine columns.
  ASSERT_NO_FATAL_FAILURE(saveAsAnOlderSchema(
      drive, file,
      "CREATE TABLE t1 AS SELECT id, utime, session_id, session_start_utime, active_node, floor, "
      "in_elevator, pose,"
      " covariance FROM map_tracking; DROP TABLE map_tracking;"
      "CREATE TABLE map_tracking (id INTEGER PRIMARY KEY CHECK (id = 0), utime INTEGER NOT NULL,"
      " session_id INTEGER NOT NULL, session_start_utime INTEGER NOT NULL, active_node INTEGER NOT "
      "NULL,"
      " floor INTEGER NOT NULL, in_elevator INTEGER NOT NULL, pose BLOB NOT NULL, covariance BLOB "
      "NOT NULL);"
      "INSERT INTO map_tracking SELECT * FROM t1; DROP TABLE t1; PRAGMA user_version=1;"));
  {
    MapSnapshot snap;
    ASSERT_NO_FATAL_FAILURE(loadReadOnly(file, &snap));
    ASSERT_TRUE(snap.tracking);
    EXPECT_FALSE(snap.tracking->odometry);
  }
  auto store = MapStore::open(file);
  ASSERT_TRUE(store) << store.error().message;
  EXPECT_EQ(*store->schemaVersion(), map::kSchemaVersion);
  auto snap = store->load();
  ASSERT_TRUE(snap && snap->tracking);
  EXPECT_FALSE(snap->tracking->odometry);
  ASSERT_TRUE(store->save(drive.mapper(), 0, 0));
  const auto saved = drive.mapper().trackingState();
  ASSERT_TRUE(saved && saved->odometry);
  auto again = store->load();
  ASSERT_TRUE(again && again->tracking && again->tracking->odometry);
  const Tracker::OdometryAnchor& a = *again->tracking->odometry;
  EXPECT_EQ(a.pose.epoch, saved->odometry->pose.epoch);
  EXPECT_EQ(a.pose.utime, saved->odometry->pose.utime);
  EXPECT_LT((a.pose.odom_T_cam.mean.inverse() * saved->odometry->pose.odom_T_cam.mean).log().norm(),
            1e-12);
  EXPECT_EQ(a.pose.odom_T_cam.covariance, saved->odometry->pose.odom_T_cam.covariance);
  EXPECT_EQ(a.own_covariance, saved->odometry->own_covariance);
  EXPECT_TRUE(store->integrityCheck());
}

// Stores of schema version 2 (map_tracking without its wheel_* columns) open read-only as
// they are and read-write migrated to the current version; the next save stores the wheels'
// odometry pose, which a load gives back as it was saved.
TEST(MapStore, AStoreOfTheSchemaBeforeTheWheelPoseIsMigratedAndTheRoundTripKeepsThePose) {
  evermap::testing::ScratchDir dir;
  const auto file = dir.path() / "v2.db";
  ScriptedDrive drive(scriptedOptions());
  drive.wheels(true);
  drive.driveTo(4.0, 0.0);
  ASSERT_NO_FATAL_FAILURE(
      saveAsAnOlderSchema(drive, file,
                          "ALTER TABLE map_tracking DROP COLUMN wheel_epoch; ALTER TABLE "
                          "map_tracking DROP COLUMN wheel_utime;"
                          "ALTER TABLE map_tracking DROP COLUMN wheel_pose; ALTER TABLE "
                          "map_tracking DROP COLUMN wheel_covariance;"
                          "PRAGMA user_version=2;"));
  {
    MapSnapshot snap;
    ASSERT_NO_FATAL_FAILURE(loadReadOnly(file, &snap));
    ASSERT_TRUE(snap.tracking);
    EXPECT_TRUE(snap.tracking->odometry);
    EXPECT_FALSE(snap.tracking->wheel);
  }
  auto store = MapStore::open(file);
  ASSERT_TRUE(store) << store.error().message;
  EXPECT_EQ(*store->schemaVersion(), map::kSchemaVersion);
  ASSERT_TRUE(store->save(drive.mapper(), 0, 0));
  const auto saved = drive.mapper().trackingState();
  ASSERT_TRUE(saved && saved->wheel);
  auto again = store->load();
  ASSERT_TRUE(again && again->tracking && again->tracking->wheel);
  const messages::WheelOdometryPose& w = *again->tracking->wheel;
  EXPECT_EQ(w.epoch, saved->wheel->epoch);
  EXPECT_EQ(w.utime, saved->wheel->utime);
  EXPECT_EQ(w.odom_T_body.vector(), saved->wheel->odom_T_body.vector());
  EXPECT_EQ(w.covariance, saved->wheel->covariance);
  EXPECT_TRUE(store->integrityCheck());
}

// Stores of schema version 3 (no map_footprints) open read-only as they are, with no footprint,
// and read-write migrated to version 4; the next save stores the mapper's footprints, which a
// load gives back in their order.
TEST(MapStore, AStoreOfTheSchemaBeforeTheFootprintsIsMigratedAndTheRoundTripKeepsThem) {
  evermap::testing::ScratchDir dir;
  const auto file = dir.path() / "v3.db";
  ScriptedDrive drive(scriptedOptions());
  lap(drive);
  ASSERT_GT(drive.mapper().footprints().size(), 0u);
  ASSERT_NO_FATAL_FAILURE(
      saveAsAnOlderSchema(drive, file, "DROP TABLE map_footprints; PRAGMA user_version=3;"));
  {
    MapSnapshot snap;
    ASSERT_NO_FATAL_FAILURE(loadReadOnly(file, &snap));
    EXPECT_TRUE(snap.footprints.empty());
    EXPECT_EQ(snap.nodes.size(), drive.mapper().nodes().size());
  }
  auto store = MapStore::open(file);
  ASSERT_TRUE(store) << store.error().message;
  EXPECT_EQ(*store->schemaVersion(), 4);
  ASSERT_TRUE(store->save(drive.mapper(), 0, 0));
  auto again = store->load();
  ASSERT_TRUE(again) << again.error().message;
  const std::vector<Footprint>& made = drive.mapper().footprints();
  ASSERT_EQ(again->footprints.size(), made.size());
  for (size_t k = 0; k < made.size(); ++k) {
    EXPECT_EQ(again->footprints[k].node, made[k].node);
    EXPECT_EQ(again->footprints[k].session, made[k].session);
    EXPECT_LT((core::toPlanar(again->footprints[k].node_T_view).vector() -
               core::toPlanar(made[k].node_T_view).vector())
                  .norm(),
              1e-12);
  }
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
