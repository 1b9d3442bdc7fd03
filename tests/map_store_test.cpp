// mapper-proc: the map store of a scripted drive (one transaction per update, every node and
// edge reloaded, a pair's constraints folded, the same map through core/map's read-only reader)
// and a file that is not one.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <string>
#include <vector>

#include "core/map/store_file.h"
#include "core/map/store_reader.h"
#include "mapper-proc/map_store.h"
#include "mapper-proc/mapper.h"
#include "tests/scratch_dir.h"
#include "tests/scripted_drive.h"

namespace evermap::mapper {
namespace {

using namespace testing;  // tests/mapper_messages.h, tests/scripted_drive.h

TEST(MapStore, SavesOneTransactionPerUpdateAndReloadsEveryNodeAndEdge) {
  evermap::testing::ScratchDir dir;
  const auto file = dir.path() / "map.db";
  ScriptedDrive drive(scriptedOptions());
  const MapStoreOptions every_row{0};  // no folds: each constraint is its own row
  {
    auto store = MapStore::open(file, every_row);
    ASSERT_TRUE(store) << store.error().message;
    lap(drive);
    ASSERT_TRUE(store->save(drive.mapper(), 0, 0));
    lap(drive);
    ASSERT_TRUE(store->save(drive.mapper(), 0, 0));
  }
  // Reopened: nothing is stored twice, and a further update appends.
  auto store = MapStore::open(file, every_row);
  ASSERT_TRUE(store) << store.error().message;
  ASSERT_TRUE(store->save(drive.mapper(), 0, 0));
  ASSERT_TRUE(store->integrityCheck());
  // Each save ends with a checkpoint: the map is in the file, the write-ahead log is empty.
  std::error_code ec;
  const auto wal_bytes = std::filesystem::file_size(file.string() + "-wal", ec);
  EXPECT_TRUE(ec || wal_bytes == 0) << wal_bytes << " bytes left in the log";
  auto snap = store->load();
  ASSERT_TRUE(snap) << snap.error().message;
  const Mapper& m = drive.mapper();
  ASSERT_EQ(snap->nodes.size(), m.nodes().size());
  ASSERT_EQ(snap->edges.size(), m.constraints().all().size());
  ASSERT_EQ(snap->sessions.size(), 1u);
  ASSERT_EQ(snap->floors.size(), 1u);
  for (const StoredNode& n : snap->nodes) {
    EXPECT_LT((n.world_T_body.inverse() * m.nodePose(n.node.id)).log().norm(), 1e-12);
    EXPECT_EQ(n.node.keyframe_utime, m.nodes()[n.node.id].keyframe_utime);
  }
  for (const StoredEdge& e : snap->edges) {
    const Constraint& c = m.constraints().all()[e.edge_id];
    EXPECT_EQ(e.constraint.from, c.from);
    EXPECT_EQ(e.constraint.to, c.to);
    EXPECT_EQ(e.constraint.accepted, c.accepted);
    EXPECT_LT((e.constraint.from_T_to.covariance - c.from_T_to.covariance).norm(), 1e-15);
  }
}

TEST(MapStore, FoldsAPairsConstraintsSoTheStoreGrowsWithTheMapNotWithTheTime) {
  // The same corridor, lap after lap: nodes stop growing after the first lap, constraints do
  // not. Unfolded, every one is a row for ever; folded, a pair keeps one row.
  evermap::testing::ScratchDir dir;
  ScriptedDrive drive(scriptedOptions());
  auto folded = MapStore::open(dir.path() / "folded.db");  // fold_after = 2
  auto plain = MapStore::open(dir.path() / "plain.db", MapStoreOptions{0});
  ASSERT_TRUE(folded && plain);
  std::vector<size_t> folded_rows, plain_rows;
  for (int k = 0; k < 8; ++k) {
    // A pause long enough to start a new session in the same mapper half-way.
    if (k == 4) drive.newSession(60.0, true);
    lap(drive);
    ASSERT_TRUE(folded->save(drive.mapper(), 0, 0));
    ASSERT_TRUE(plain->save(drive.mapper(), 0, 0));
    folded_rows.push_back(folded->load()->edges.size());
    plain_rows.push_back(plain->load()->edges.size());
  }
  const Mapper& m = drive.mapper();
  const size_t pairs = m.constraints().pairs().size();
  EXPECT_EQ(plain_rows.back(), m.constraints().all().size());
  EXPECT_GT(plain_rows.back(), plain_rows[1] + 30);  // grows with the time
  // Grows with the pairs: one row each, beside the rows of rejected constraints whose pair
  // holds no accepted one (not a pair of the map, never folded).
  int64_t rejected = 0;
  for (const Constraint& c : m.constraints().all()) rejected += c.accepted ? 0 : 1;
  EXPECT_LE(folded_rows.back(), pairs + static_cast<size_t>(rejected));
  EXPECT_LE(folded_rows.back(), folded_rows[1] + 2);
  // The pages folds freed went back to the file system: the file is the map.
  {
    sqlite3* db = nullptr;
    ASSERT_EQ(
        sqlite3_open_v2((dir.path() / "folded.db").c_str(), &db, SQLITE_OPEN_READONLY, nullptr),
        SQLITE_OK);
    sqlite3_stmt* st = nullptr;
    ASSERT_EQ(sqlite3_prepare_v2(db, "PRAGMA freelist_count", -1, &st, nullptr), SQLITE_OK);
    ASSERT_EQ(sqlite3_step(st), SQLITE_ROW);
    EXPECT_EQ(sqlite3_column_int64(st, 0), 0);
    sqlite3_finalize(st);
    sqlite3_close(db);
  }
  ASSERT_TRUE(folded->integrityCheck());
  auto snap = folded->load();
  ASSERT_TRUE(snap);
  EXPECT_EQ(snap->constraintsRepresented(), static_cast<int64_t>(m.constraints().all().size()));

  // Restored, the folded store gives every pair the estimate the live mapper had merged.
  Mapper restored{scriptedOptions()};
  ASSERT_TRUE(restored.restore(*snap));
  ASSERT_EQ(restored.constraints().pairs().size(), pairs);
  for (const auto& [key, pair] : m.constraints().pairs()) {
    const auto it = restored.constraints().pairs().find(key);
    ASSERT_NE(it, restored.constraints().pairs().end());
    EXPECT_LT((pair.i_T_j.mean.inverse() * it->second.i_T_j.mean).log().norm(), 1e-9)
        << key.first << "-" << key.second;
    EXPECT_LT((pair.i_T_j.covariance - it->second.i_T_j.covariance).norm(),
              1e-9 * pair.i_T_j.covariance.norm());
  }
  // A fold sits where its pair's first constraint sat: the unfolded store numbers every
  // constraint as it came, and the fold has the id that store gave the pair's first one. A
  // fold given a new id would go to the end of the file and leave a hole in the page of the
  // row it replaced, for good (rowids only grow): the file would grow with the folds, i.e.
  // with the visits (issue 22: +30 % over a simulated year while the rows grew 15 %).
  {
    auto unfolded = plain->load();
    ASSERT_TRUE(unfolded);
    auto pairOf = [](const StoredEdge& e) {
      return std::make_pair(std::min(e.constraint.from, e.constraint.to),
                            std::max(e.constraint.from, e.constraint.to));
    };
    std::map<std::pair<int64_t, int64_t>, int64_t> first_id;
    for (const StoredEdge& e : unfolded->edges) first_id.emplace(pairOf(e), e.edge_id);
    int folds = 0;
    for (const StoredEdge& e : snap->edges) {
      if (e.folded == 0) continue;
      ++folds;
      const auto key = pairOf(e);
      EXPECT_EQ(e.edge_id, first_id.at(key)) << key.first << "-" << key.second;
    }
    EXPECT_GT(folds, 5);
  }
  // Nothing of the current mapper is stored twice by a store opened anew.
  auto reopened = MapStore::open(dir.path() / "folded.db");
  ASSERT_TRUE(reopened && reopened->save(drive.mapper(), 0, 0));
  EXPECT_EQ(reopened->load()->edges.size(), folded_rows.back());
}

// The viewer's path (core/map): a read-only open reads what the mapper's store loads, and
// leaves the file as it was.
TEST(MapStore, AReadOnlyReaderLoadsWhatTheMapperSavedAndWritesNothing) {
  evermap::testing::ScratchDir dir;
  const auto file = dir.path() / "map.db";
  ScriptedDrive drive(scriptedOptions());
  auto store = MapStore::open(file);
  ASSERT_TRUE(store) << store.error().message;
  lap(drive);
  lap(drive);
  ASSERT_TRUE(store->save(drive.mapper(), 0, 0));
  auto saved = store->load();
  ASSERT_TRUE(saved) << saved.error().message;
  auto bytes = [&file] {
    std::ifstream in(file, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  const std::string before = bytes();
  auto reader = map::StoreFile::open(file, /*read_only=*/true);
  ASSERT_TRUE(reader) << reader.error().message;
  auto read = map::readMap(*reader);
  ASSERT_TRUE(read) << read.error().message;
  EXPECT_EQ(bytes(), before);
  ASSERT_EQ(read->nodes.size(), saved->nodes.size());
  ASSERT_EQ(read->edges.size(), saved->edges.size());
  EXPECT_EQ(read->constraintsRepresented(), saved->constraintsRepresented());
  EXPECT_EQ(read->tracking.has_value(), saved->tracking.has_value());
  for (size_t k = 0; k < read->edges.size(); ++k) {
    EXPECT_EQ(read->edges[k].edge_id, saved->edges[k].edge_id);
    EXPECT_EQ(read->edges[k].folded, saved->edges[k].folded);
  }
  auto missing = map::StoreFile::open(dir.path() / "none.db", /*read_only=*/true);
  ASSERT_FALSE(missing);
  EXPECT_NE(missing.error().message.find("none.db"), std::string::npos);
}

TEST(MapStore, RejectsAFileThatIsNotAMapStore) {
  evermap::testing::ScratchDir dir;
  const auto file = dir.path() / "junk.db";
  {
    std::ofstream out(file);
    out << "this is not sqlite";
  }
  auto store = MapStore::open(file);
  ASSERT_FALSE(store);
  EXPECT_NE(store.error().message.find("junk.db"), std::string::npos);
}

}  // namespace
}  // namespace evermap::mapper
