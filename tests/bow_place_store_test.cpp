// core/bow/place_store: places and keyframes survive a close and reopen of the SQLite map store,
// the store is in WAL mode and bound to its vocabulary, a failed batch writes nothing, and
// damaged rows are reported, not crashed on.
#include <gtest/gtest.h>

#include <sqlite3.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fstream>

#include "core/bow/place_store.h"
#include "tests/register_results.h"

namespace evermap::bow {
namespace {

namespace fs = std::filesystem;

class PlaceStoreTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("evermap_place_store_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    file_ = dir_ / "map.db";
  }
  void TearDown() override { fs::remove_all(dir_); }

  // Runs one SQL statement on the file with a connection of its own.
  void rawSql(const std::string& sql) {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(file_.c_str(), &db), SQLITE_OK);
    char* err = nullptr;
    EXPECT_EQ(sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &err), SQLITE_OK) << (err ? err : "");
    sqlite3_free(err);
    sqlite3_close(db);
  }

  fs::path dir_;
  fs::path file_;
};

constexpr uint64_t kFingerprint = 0x1234abcd5678ef00ull;
constexpr size_t kWords = 100;

Place place(int64_t id, int32_t floor, BowVector bow) {
  return Place{id, floor, 1000 * id, std::move(bow)};
}

evermap::keyframe_t keyframe(int64_t utime, int n) {
  evermap::keyframe_t k = evermap::testing::emptyKeyframe(utime);
  k.num_features = n;
  for (int i = 0; i < n; ++i) {
    k.keypoints.push_back({static_cast<float>(i), static_cast<float>(2 * i)});
    k.points.push_back({0.1f * i, 0.2f, 3.0f});
    k.disparity.push_back(10.0f + i);
    k.level.push_back(static_cast<int8_t>(i % 3));
    k.descriptors.push_back(std::vector<uint8_t>(32, static_cast<uint8_t>(i)));
  }
  return k;
}

TEST_F(PlaceStoreTest, PlacesSurviveReopeningAndQueryAlike) {
  const std::vector<Place> first = {place(1, 0, {{3, 0.5f}, {7, 0.5f}}), place(2, 0, {{3, 1.0f}})};
  const std::vector<Place> second = {place(3, 1, {{7, 0.25f}, {99, 0.75f}})};
  {
    auto store = PlaceStore::open(file_, kFingerprint, kWords);
    ASSERT_TRUE(store.ok()) << store.error().message;
    ASSERT_TRUE(store->savePlaces(first).ok());
    ASSERT_TRUE(store->savePlaces(second).ok());
  }
  auto store = PlaceStore::open(file_, kFingerprint, kWords);
  ASSERT_TRUE(store.ok()) << store.error().message;
  auto places = store->loadPlaces();
  ASSERT_TRUE(places.ok()) << places.error().message;
  ASSERT_EQ(places->size(), 3u);
  for (size_t i = 0; i < 3; ++i) {
    const Place& expected = i < 2 ? first[i] : second[0];
    EXPECT_EQ((*places)[i].id, expected.id);
    EXPECT_EQ((*places)[i].floor, expected.floor);
    EXPECT_EQ((*places)[i].utime, expected.utime);
    EXPECT_EQ((*places)[i].bow, expected.bow);  // float weights stored bit for bit
  }
  auto db = store->loadDatabase();
  ASSERT_TRUE(db.ok());
  EXPECT_EQ(db->vocabularyFingerprint(), kFingerprint);
  auto r = db->query({{3, 0.5f}, {7, 0.5f}}, {});
  ASSERT_TRUE(r.ok());
  ASSERT_EQ(r->size(), 3u);
  EXPECT_EQ((*r)[0].id, 1);
  EXPECT_NEAR((*r)[0].score, 1.0, 1e-6);
}

TEST_F(PlaceStoreTest, TheFileIsInWalMode) {
  ASSERT_TRUE(PlaceStore::open(file_, kFingerprint, kWords).ok());
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(file_.c_str(), &db), SQLITE_OK);
  sqlite3_stmt* stmt = nullptr;
  ASSERT_EQ(sqlite3_prepare_v2(db, "PRAGMA journal_mode", -1, &stmt, nullptr), SQLITE_OK);
  ASSERT_EQ(sqlite3_step(stmt), SQLITE_ROW);
  EXPECT_STREQ(reinterpret_cast<const char*>(sqlite3_column_text(stmt, 0)), "wal");
  sqlite3_finalize(stmt);
  sqlite3_close(db);
}

TEST_F(PlaceStoreTest, AnotherVocabularyIsRefused) {
  ASSERT_TRUE(PlaceStore::open(file_, kFingerprint, kWords).ok());
  auto other = PlaceStore::open(file_, kFingerprint + 1, kWords);
  ASSERT_FALSE(other.ok());
  EXPECT_NE(other.error().message.find(file_.string()), std::string::npos);
  EXPECT_NE(other.error().message.find("1234abcd5678ef00"), std::string::npos)
      << other.error().message;
  EXPECT_FALSE(PlaceStore::open(file_, kFingerprint, kWords + 1).ok());
}

// Localization (docs/localization.md) reads the map's places and writes nothing.
TEST_F(PlaceStoreTest, AReadOnlyStoreLoadsItsPlacesRefusesWritesAndLeavesTheBytesAlone) {
  {
    auto store = PlaceStore::open(file_, kFingerprint, kWords);
    ASSERT_TRUE(store.ok()) << store.error().message;
    ASSERT_TRUE(store->savePlaces(std::vector<Place>{place(1, 0, {{3, 1.0f}})}).ok());
    ASSERT_TRUE(store->saveKeyframes(std::vector<evermap::keyframe_t>{keyframe(1000, 3)}).ok());
  }
  auto bytes = [this] {
    std::ifstream in(file_, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  const std::string before = bytes();
  {
    auto store = PlaceStore::openReadOnly(file_, kFingerprint, kWords);
    ASSERT_TRUE(store.ok()) << store.error().message;
    auto places = store->loadPlaces();
    ASSERT_TRUE(places.ok());
    EXPECT_EQ(places->size(), 1u);
    auto k = store->loadKeyframe(1000);
    ASSERT_TRUE(k.ok());
    EXPECT_TRUE(k->has_value());
    EXPECT_FALSE(store->savePlaces(std::vector<Place>{place(2, 0, {{4, 1.0f}})}).ok());
    EXPECT_FALSE(store->saveKeyframes(std::vector<evermap::keyframe_t>{keyframe(2000, 3)}).ok());
  }
  EXPECT_EQ(bytes(), before);
  EXPECT_FALSE(PlaceStore::openReadOnly(file_, kFingerprint + 1, kWords).ok());
  EXPECT_FALSE(PlaceStore::openReadOnly(dir_ / "absent.db", kFingerprint, kWords).ok());
  EXPECT_FALSE(fs::exists(dir_ / "absent.db"));
}

TEST_F(PlaceStoreTest, AFailedBatchWritesNothing) {
  auto store = PlaceStore::open(file_, kFingerprint, kWords);
  ASSERT_TRUE(store.ok());
  ASSERT_TRUE(store->savePlaces(std::vector<Place>{place(1, 0, {{1, 1.0f}})}).ok());
  const std::vector<Place> bad = {place(2, 0, {{1, 1.0f}}), place(3, 0, {{kWords, 1.0f}})};
  const Status s = store->savePlaces(bad);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("place 3"), std::string::npos);
  EXPECT_EQ(store->loadPlaces()->size(), 1u);
  // Saving an id again replaces it.
  ASSERT_TRUE(store->savePlaces(std::vector<Place>{place(1, 4, {{2, 1.0f}})}).ok());
  auto places = store->loadPlaces();
  ASSERT_EQ(places->size(), 1u);
  EXPECT_EQ((*places)[0].floor, 4);
}

TEST_F(PlaceStoreTest, AnUncommittedTransactionOfAKilledProcessLeavesTheLastCommit) {
  {
    auto store = PlaceStore::open(file_, kFingerprint, kWords);
    ASSERT_TRUE(store.ok());
    ASSERT_TRUE(store->savePlaces(std::vector<Place>{place(1, 0, {{1, 1.0f}})}).ok());
  }
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    // Half a batch, then the process dies without committing or closing.
    sqlite3* db = nullptr;
    sqlite3_open(file_.c_str(), &db);
    sqlite3_exec(db, "BEGIN; INSERT INTO bow_places VALUES (2, 0, 0, x'0100000000000000');",
                 nullptr, nullptr, nullptr);
    ::_exit(0);
  }
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  auto store = PlaceStore::open(file_, kFingerprint, kWords);
  ASSERT_TRUE(store.ok()) << store.error().message;
  auto places = store->loadPlaces();
  ASSERT_TRUE(places.ok());
  ASSERT_EQ(places->size(), 1u);
  EXPECT_EQ((*places)[0].id, 1);
}

TEST_F(PlaceStoreTest, KeyframesRoundTripAndBadOnesAreRefused) {
  auto store = PlaceStore::open(file_, kFingerprint, kWords);
  ASSERT_TRUE(store.ok());
  const std::vector<evermap::keyframe_t> batch = {keyframe(100, 5), keyframe(200, 0)};
  ASSERT_TRUE(store->saveKeyframes(batch).ok());
  auto k = store->loadKeyframe(100);
  ASSERT_TRUE(k.ok()) << k.error().message;
  ASSERT_TRUE(k->has_value());
  EXPECT_EQ((*k)->num_features, 5);
  EXPECT_EQ((*k)->descriptors[4], std::vector<uint8_t>(32, 4));
  EXPECT_FLOAT_EQ((*k)->points[2][0], 0.2f);
  EXPECT_DOUBLE_EQ((*k)->baseline_m, 0.11);
  auto none = store->loadKeyframe(150);
  ASSERT_TRUE(none.ok());
  EXPECT_FALSE(none->has_value());
  EXPECT_EQ(*store->keyframeUtimes(), (std::vector<int64_t>{100, 200}));

  evermap::keyframe_t inconsistent = keyframe(300, 3);
  inconsistent.num_features = 4;
  const Status s = store->saveKeyframes(std::vector<evermap::keyframe_t>{inconsistent});
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("keyframe 300"), std::string::npos);
  EXPECT_EQ(store->keyframeUtimes()->size(), 2u);
}

TEST_F(PlaceStoreTest, DamagedRowsAreReportedWithTheirKey) {
  {
    auto store = PlaceStore::open(file_, kFingerprint, kWords);
    ASSERT_TRUE(store.ok());
  }
  rawSql("INSERT INTO bow_places VALUES (42, 0, 0, x'01020304050607');");  // 7 bytes
  rawSql("INSERT INTO keyframes VALUES (77, x'00010203');");
  auto store = PlaceStore::open(file_, kFingerprint, kWords);
  ASSERT_TRUE(store.ok());
  auto places = store->loadPlaces();
  ASSERT_FALSE(places.ok());
  EXPECT_NE(places.error().message.find("place 42"), std::string::npos) << places.error().message;
  auto k = store->loadKeyframe(77);
  ASSERT_FALSE(k.ok());
  EXPECT_NE(k.error().message.find("keyframe 77"), std::string::npos) << k.error().message;
}

TEST_F(PlaceStoreTest, AFileThatIsNotSqliteIsAnError) {
  std::ofstream(file_) << "this is not a database, just some text that is long enough........";
  auto store = PlaceStore::open(file_, kFingerprint, kWords);
  ASSERT_FALSE(store.ok());
  EXPECT_NE(store.error().message.find(file_.string()), std::string::npos);
  auto missing_dir = PlaceStore::open(dir_ / "no" / "map.db", kFingerprint, kWords);
  EXPECT_FALSE(missing_dir.ok());
}

TEST(BowBlob, EncodeDecodeRoundTripAndChecks) {
  const BowVector v = {{0, 0.125f}, {9, 0.375f}, {4000000000u, 0.5f}};
  const auto blob = encodeBowVector(v);
  EXPECT_EQ(blob.size(), 24u);
  EXPECT_EQ(blob[8], 9);  // little-endian word of the second entry
  auto back = decodeBowVector(blob, 4000000001u);
  ASSERT_TRUE(back.ok());
  EXPECT_EQ(*back, v);
  EXPECT_FALSE(decodeBowVector(blob, 4000000000u).ok());
  EXPECT_FALSE(decodeBowVector(std::span<const uint8_t>(blob.data(), 23), 4000000001u).ok());
}

}  // namespace
}  // namespace evermap::bow
