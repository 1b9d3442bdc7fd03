// core/bow/place_database: the inverted-index query agrees with brute-force L1 scores, and
// floors, recent-frame exclusion, top-k and bad input behave as documented.
#include <gtest/gtest.h>

#include <algorithm>

#include "core/bow/place_database.h"
#include "tools/vocab-train/kmajority.h"

namespace evermap::bow {
namespace {

// A random L1-normalised vector over `num_words` words with about `size` entries.
BowVector randomBow(SplitMix64& rng, uint32_t num_words, int size) {
  std::vector<uint32_t> words;
  for (int i = 0; i < size; ++i) words.push_back(static_cast<uint32_t>(rng.below(num_words)));
  std::sort(words.begin(), words.end());
  words.erase(std::unique(words.begin(), words.end()), words.end());
  BowVector v;
  double total = 0;
  for (uint32_t w : words) {
    const float x = static_cast<float>(0.1 + rng.uniform());
    v.push_back({w, x});
    total += x;
  }
  for (auto& e : v) e.weight = static_cast<float>(e.weight / total);
  return v;
}

Place place(int64_t id, int32_t floor, int64_t utime, BowVector bow) {
  return Place{id, floor, utime, std::move(bow)};
}

TEST(PlaceDatabase, QueryScoresEqualBruteForceL1Scores) {
  SplitMix64 rng(17);
  constexpr uint32_t kWords = 300;
  PlaceDatabase db(kWords, 0xABC);
  std::vector<BowVector> stored;
  for (int i = 0; i < 200; ++i) {
    stored.push_back(randomBow(rng, kWords, 40));
    ASSERT_TRUE(db.insert(place(i, i % 3, 1000 * i, stored.back())).ok());
  }
  EXPECT_EQ(db.size(), 200u);
  for (int trial = 0; trial < 20; ++trial) {
    const BowVector q = randomBow(rng, kWords, 40);
    PlaceQuery query;
    query.top_k = 1000;
    auto result = db.query(q, query);
    ASSERT_TRUE(result.ok());
    // Every place sharing a word is returned, with its L1 score, best first.
    size_t sharing = 0;
    for (size_t i = 0; i < stored.size(); ++i) sharing += l1Score(q, stored[i]) > 0 ? 1 : 0;
    EXPECT_EQ(result->size(), sharing);
    for (size_t k = 0; k < result->size(); ++k) {
      const PlaceMatch& m = (*result)[k];
      EXPECT_NEAR(m.score, l1Score(q, stored[static_cast<size_t>(m.id)]), 1e-5);
      EXPECT_EQ(m.floor, m.id % 3);
      EXPECT_EQ(m.utime, 1000 * m.id);
      if (k > 0) {
        EXPECT_LE(m.score, (*result)[k - 1].score);
      }
    }
  }
}

TEST(PlaceDatabase, AnIdenticalVectorScoresOneAndComesFirst) {
  SplitMix64 rng(2);
  PlaceDatabase db(1000, 1);
  std::vector<BowVector> stored;
  for (int i = 0; i < 50; ++i) {
    stored.push_back(randomBow(rng, 1000, 80));
    ASSERT_TRUE(db.insert(place(100 + i, 0, i, stored.back())).ok());
  }
  PlaceQuery q;
  q.top_k = 3;
  auto r = db.query(stored[23], q);
  ASSERT_TRUE(r.ok());
  ASSERT_EQ(r->size(), 3u);
  EXPECT_EQ((*r)[0].id, 123);
  EXPECT_NEAR((*r)[0].score, 1.0, 1e-5);
  EXPECT_LT((*r)[1].score, 0.5);
}

TEST(PlaceDatabase, QueriesStayOnTheirFloor) {
  PlaceDatabase db(10, 1);
  const BowVector v = {{1, 0.5f}, {2, 0.5f}};
  ASSERT_TRUE(db.insert(place(1, 0, 10, v)).ok());
  ASSERT_TRUE(db.insert(place(2, 3, 20, v)).ok());
  ASSERT_TRUE(db.insert(place(3, 3, 30, v)).ok());
  PlaceQuery q;
  q.floor = 3;
  auto r = db.query(v, q);
  ASSERT_TRUE(r.ok());
  ASSERT_EQ(r->size(), 2u);
  for (const auto& m : *r) EXPECT_EQ(m.floor, 3);
  q.floor = 7;
  EXPECT_TRUE(db.query(v, q)->empty());
  q.floor.reset();
  EXPECT_EQ(db.query(v, q)->size(), 3u);
}

TEST(PlaceDatabase, RecentPlacesAreExcludedByTimeOrId) {
  PlaceDatabase db(10, 1);
  const BowVector v = {{4, 1.0f}};
  for (int i = 1; i <= 5; ++i) ASSERT_TRUE(db.insert(place(i, 0, 100 * i, v)).ok());
  PlaceQuery q;
  q.newest_utime = 300;
  auto r = db.query(v, q);
  ASSERT_TRUE(r.ok());
  ASSERT_EQ(r->size(), 3u);  // utime 100, 200, 300
  for (const auto& m : *r) EXPECT_LE(m.utime, 300);
  q.newest_utime = std::numeric_limits<int64_t>::max();
  q.newest_id = 1;
  r = db.query(v, q);
  ASSERT_EQ(r->size(), 1u);
  EXPECT_EQ((*r)[0].id, 1);
}

TEST(PlaceDatabase, TopKMinScoreTiesAndNormalisedScore) {
  PlaceDatabase db(10, 1);
  ASSERT_TRUE(db.insert(place(7, 0, 0, {{1, 0.5f}, {2, 0.5f}})).ok());
  ASSERT_TRUE(db.insert(place(5, 0, 0, {{1, 0.5f}, {2, 0.5f}})).ok());
  ASSERT_TRUE(db.insert(place(9, 0, 0, {{1, 0.25f}, {3, 0.75f}})).ok());
  const BowVector q = {{1, 0.5f}, {2, 0.5f}};
  PlaceQuery query;
  query.top_k = 2;
  query.reference_score = 0.5;
  auto r = db.query(q, query);
  ASSERT_TRUE(r.ok());
  ASSERT_EQ(r->size(), 2u);
  // Equal scores: the smaller id first.
  EXPECT_EQ((*r)[0].id, 5);
  EXPECT_EQ((*r)[1].id, 7);
  EXPECT_DOUBLE_EQ((*r)[0].normalized_score, 2.0);  // 1 / 0.5 (DBoW2 eq. 3)
  query.top_k = 10;
  query.min_score = 0.5;
  EXPECT_EQ(db.query(q, query)->size(), 2u);  // place 9 scores 0.25
  query.min_score = 0.0;
  query.reference_score = 0.0;
  r = db.query(q, query);
  EXPECT_EQ(r->size(), 3u);
  EXPECT_DOUBLE_EQ(r->back().score, 0.25);
  EXPECT_DOUBLE_EQ(r->back().normalized_score, 0.0);
}

TEST(PlaceDatabase, EachFloorCostsItsPostingsNotTheWholeVocabulary) {
  // issue 17: places on 400 floors of a 1,000,000-word vocabulary. A dense index per floor
  // held 400 x 1,000,000 empty lists (9.6 GB); the sparse one holds a list per (floor, word)
  // posted, and still answers per floor and over every floor.
  constexpr uint32_t kWords = 1'000'000;
  PlaceDatabase db(kWords, 1);
  SplitMix64 rng(4);
  std::vector<BowVector> bows;
  for (int32_t floor = 0; floor < 400; ++floor) {
    bows.push_back(randomBow(rng, kWords, 5));
    ASSERT_TRUE(db.insert(place(floor, floor, floor, bows.back())).ok());
  }
  EXPECT_EQ(db.numPostingLists(), db.numPostings());  // 5 random words of 10^6: all distinct
  EXPECT_LE(db.numPostings(), 2000u);
  PlaceQuery q;
  q.floor = 123;
  auto on_floor = db.query(bows[123], q);
  ASSERT_TRUE(on_floor.ok());
  ASSERT_EQ(on_floor->size(), 1u);
  EXPECT_EQ(on_floor->front().id, 123);
  EXPECT_NEAR(on_floor->front().score, 1.0, 1e-6);
  q.floor = 124;
  EXPECT_TRUE(db.query(bows[123], q)->empty());
  q.floor.reset();
  auto any = db.query(bows[7], q);
  ASSERT_TRUE(any.ok());
  ASSERT_FALSE(any->empty());
  EXPECT_EQ(any->front().id, 7);
}

TEST(PlaceDatabase, BadInsertionsAndQueriesAreErrorsNotCrashes) {
  PlaceDatabase db(10, 1);
  ASSERT_TRUE(db.insert(place(1, 0, 0, {{1, 1.0f}})).ok());
  EXPECT_FALSE(db.insert(place(1, 0, 0, {{2, 1.0f}})).ok());  // duplicate id
  auto out_of_range = db.insert(place(2, 0, 0, {{10, 1.0f}}));
  ASSERT_FALSE(out_of_range.ok());
  EXPECT_NE(out_of_range.error().message.find("word 10"), std::string::npos);
  EXPECT_FALSE(db.insert(place(3, 0, 0, {{2, 0.5f}, {1, 0.5f}})).ok());  // unsorted
  EXPECT_FALSE(db.insert(place(4, 0, 0, {{2, std::nanf("")}})).ok());
  EXPECT_EQ(db.size(), 1u);
  EXPECT_EQ(db.numPostings(), 1u);
  EXPECT_FALSE(db.query({{11, 1.0f}}, {}).ok());
  PlaceQuery q;
  q.top_k = 0;
  EXPECT_FALSE(db.query({{1, 1.0f}}, q).ok());
  // An empty vector (an image without words) finds nothing, without error.
  auto empty = db.query({}, {});
  ASSERT_TRUE(empty.ok());
  EXPECT_TRUE(empty->empty());
  ASSERT_TRUE(db.insert(place(5, 0, 0, {})).ok());
  EXPECT_NE(db.find(5), nullptr);
  EXPECT_EQ(db.find(6), nullptr);
}

}  // namespace
}  // namespace evermap::bow
