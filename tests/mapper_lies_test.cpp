// mapper-proc after well-formed lies (issue 47): nothing lasts that the real streams
// contradict. A first session no registration ever confirmed (made from fuzzed odometry) is
// quarantined and the next session maps; a floor's first height is replaced when later reports
// contradict it, and a floor no node is on is no floor of the map. (The message clock's part:
// messages_inbox_test.)

#include <gtest/gtest.h>

#include <cstdint>
#include <string>

#include "mapper-proc/floor_state.h"
#include "mapper-proc/map_store.h"
#include "mapper-proc/mapper.h"
#include "tests/mapper_messages.h"
#include "tests/scratch_dir.h"
#include "tests/scripted_drive.h"

namespace evermap::mapper {
namespace {

using namespace testing;  // tests/mapper_messages.h, tests/scripted_drive.h

TEST(Quarantine, AFirstSessionNoRegistrationConfirmedIsQuarantinedAndTheNextSessionMaps) {
  // A phantom session: odometry that made nodes, and no registration of its keyframes ever
  // succeeded (fuzzed VO_DELTA and KEYFRAME, a stranger's stream).
  ScriptedDrive drive(scriptedOptions());
  drive.blind(true);
  drive.driveTo(3.0, 0.0);
  const auto phantom = static_cast<int64_t>(drive.mapper().nodes().size());
  ASSERT_GT(phantom, 1);
  EXPECT_EQ(drive.mapper().stats().registrations_ok, 0);
  drive.blind(false);
  drive.newSession(3600.0, true);
  // Not lost: there is nothing confirmed to re-localise on. The session starts the map afresh.
  EXPECT_FALSE(drive.mapper().lost());
  EXPECT_EQ(drive.mapper().session(), 1);
  EXPECT_EQ(drive.mapper().stats().sessions_quarantined, 1);
  EXPECT_EQ(drive.mapper().stats().nodes_quarantined, phantom);
  const std::vector<std::string> notes = drive.mapper().takeNotes();
  ASSERT_EQ(notes.size(), 1u);
  EXPECT_NE(notes[0].find("session 0 quarantined"), std::string::npos) << notes[0];
  lap(drive);
  // It maps as a first session does, over the phantom's places too (they are no places of the
  // map), and the global searches that find a phantom node are refused.
  const auto nodes = static_cast<int64_t>(drive.mapper().nodes().size());
  EXPECT_GE(nodes - phantom, 8);
  for (int64_t id = 0; id < nodes; ++id) {
    EXPECT_EQ(drive.mapper().quarantined(id), id < phantom) << id;
    if (id >= phantom) {
      EXPECT_EQ(drive.mapper().nodes()[static_cast<size_t>(id)].session, 1);
    }
  }
  EXPECT_GT(drive.mapper().stats().registrations_ok, 0);
  EXPECT_FALSE(drive.mapper().lost());

  // Stored and read back, the map's two parts are each held by their origin prior: every
  // node stays where it was.
  evermap::testing::ScratchDir dir;
  auto store = MapStore::open(dir.path() / "map.db");
  ASSERT_TRUE(store) << store.error().message;
  ASSERT_TRUE(store->save(drive.mapper(), drive.mapper().session(), 0));
  auto snap = store->load();
  ASSERT_TRUE(snap) << snap.error().message;
  Mapper reloaded(scriptedOptions());
  ASSERT_TRUE(reloaded.restore(*snap));
  for (int64_t id = 0; id < nodes; ++id)
    EXPECT_LT((reloaded.nodePose(id).inverse() * drive.mapper().nodePose(id)).log().norm(), 1e-6)
        << id;
}

TEST(Quarantine, ASessionARegistrationConfirmedIsNeverQuarantined) {
  ScriptedDrive drive(scriptedOptions());
  lap(drive);
  const int64_t nodes = drive.mapper().stats().nodes;
  drive.newSession(3600.0, true);
  EXPECT_TRUE(drive.mapper().lost());  // placed on the map by global registrations, as before
  lap(drive);
  EXPECT_FALSE(drive.mapper().lost());
  EXPECT_EQ(drive.mapper().stats().sessions_quarantined, 0);
  EXPECT_EQ(drive.mapper().stats().nodes, nodes);
  EXPECT_TRUE(drive.mapper().takeNotes().empty());
}

// FLOOR as elevator-proc sends it, through the mapper's checks.
void report(FloorState& floors, int64_t utime, int8_t event, double height_m, int index) {
  bool implausible = false;
  const floor_t msg = floorMsg(utime, event, height_m, index);
  ASSERT_TRUE(floors.check(msg, &implausible));
  if (event == floor_t::EVENT_RIDE_START)
    floors.rideStarts(msg);
  else
    floors.reach(msg);
}

TEST(FloorHeights, AFloorsFirstHeightIsReplacedWhenTheNextReportContradictsIt) {
  FloorState floors(1.0, FloorGateOptions{});
  report(floors, 1'000'000, floor_t::EVENT_NONE, 7.3, 0);  // forged
  report(floors, 2'000'000, floor_t::EVENT_NONE, 0.0, 0);  // the real session's start
  EXPECT_EQ(floors.heightM(), 0.0);
  EXPECT_EQ(floors.table().at(0), 0.0);
  EXPECT_EQ(floors.heightsReplaced(), 1);
  const std::vector<std::string> notes = floors.takeNotes();
  ASSERT_EQ(notes.size(), 1u);
  EXPECT_NE(notes[0].find("floor 0: height 7.300 m replaced by 0.000 m"), std::string::npos)
      << notes[0];
  // Confirmed by a second report (the ride's start), a forged height must outnumber it.
  report(floors, 3'000'000, floor_t::EVENT_RIDE_START, 0.05, -1);
  report(floors, 4'000'000, floor_t::EVENT_NONE, 7.3, 0);
  EXPECT_EQ(floors.table().at(0), 0.0);
  EXPECT_EQ(floors.heightsReplaced(), 1);
  report(floors, 5'000'000, floor_t::EVENT_NONE, 7.3, 0);
  EXPECT_EQ(floors.table().at(0), 7.3);  // three reports against two
  EXPECT_EQ(floors.heightsReplaced(), 2);
}

TEST(FloorHeights, ReportsWithinTheMatchDistanceKeepTheFirstHeight) {
  // Each ride's estimate differs from the floor's by the ride's error: the floor keeps one
  // height, its first report's, as before (no replacement, nothing noted).
  FloorState floors(1.0, FloorGateOptions{});
  report(floors, 1'000'000, floor_t::EVENT_NONE, 0.0, 0);
  report(floors, 2'000'000, floor_t::EVENT_RIDE_START, 0.3, -1);
  report(floors, 9'000'000, floor_t::EVENT_RIDE_END, 3.5, 1);
  report(floors, 12'000'000, floor_t::EVENT_RIDE_START, 3.2, -1);
  report(floors, 19'000'000, floor_t::EVENT_RIDE_END, -0.4, 0);
  EXPECT_EQ(floors.floor(), 0);
  EXPECT_EQ(floors.heightM(), 0.0);
  EXPECT_EQ(floors.heightsReplaced(), 0);
  EXPECT_TRUE(floors.takeNotes().empty());
}

TEST(FloorHeights, AFloorNoNodeIsOnIsNoFloorOfTheMap) {
  FloorState floors(1.0, FloorGateOptions{});
  report(floors, 1'000'000, floor_t::EVENT_NONE, 21.0, 7);  // forged: no node is ever made there
  report(floors, 2'000'000, floor_t::EVENT_NONE, 0.0, 0);
  EXPECT_EQ(floors.table(), (std::map<int, double>{{0, 0.0}}));  // the current floor only
  floors.nodesOn(0, 1);
  report(floors, 3'000'000, floor_t::EVENT_RIDE_START, 0.0, -1);
  report(floors, 9'000'000, floor_t::EVENT_RIDE_END, 3.5, 1);
  EXPECT_EQ(floors.table(), (std::map<int, double>{{0, 0.0}, {1, 3.5}}));
  floors.nodesOn(0, -1);  // its node quarantined
  EXPECT_EQ(floors.table(), (std::map<int, double>{{1, 3.5}}));
}

}  // namespace
}  // namespace evermap::mapper
