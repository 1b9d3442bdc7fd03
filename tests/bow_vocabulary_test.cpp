// core/bow: descriptors, k-majority clustering, the vocabulary tree (structure checks,
// quantisation, tf-idf vectors, L1 score) and training, on synthetic descriptors whose answer
// is known.
#include <gtest/gtest.h>

#include <cmath>
#include <numeric>

#include "bow_synthetic.h"
#include "core/bow/vocabulary.h"
#include "tools/vocab-train/kmajority.h"
#include "tools/vocab-train/vocabulary_training.h"

namespace evermap::bow {
namespace {

using testing::flipBits;
using testing::randomDescriptor;

Descriptor withBits(std::initializer_list<int> bits) {
  Descriptor d;
  for (int b : bits) d.setBit(b);
  return d;
}

TEST(Descriptor, HammingDistanceCountsDifferingBits) {
  EXPECT_EQ(hammingDistance(Descriptor{}, Descriptor{}), 0);
  EXPECT_EQ(hammingDistance(withBits({0, 63, 64, 255}), Descriptor{}), 4);
  EXPECT_EQ(hammingDistance(withBits({0, 1}), withBits({1, 2})), 2);
  Descriptor all;
  all.bytes.fill(0xFF);
  EXPECT_EQ(hammingDistance(all, Descriptor{}), 256);
  SplitMix64 rng(5);
  const Descriptor a = randomDescriptor(rng);
  EXPECT_EQ(hammingDistance(a, flipBits(a, 17, rng)), 17);
}

TEST(Descriptor, MatRoundTripKeepsBytesAndRejectsOtherShapes) {
  SplitMix64 rng(1);
  std::vector<Descriptor> d = {randomDescriptor(rng), randomDescriptor(rng)};
  const cv::Mat m = descriptorsToMat(d);
  ASSERT_EQ(m.rows, 2);
  EXPECT_EQ(m.at<uint8_t>(1, 31), d[1].bytes[31]);
  auto back = descriptorsFromMat(m, "test");
  ASSERT_TRUE(back.ok());
  EXPECT_EQ(*back, d);
  auto bad = descriptorsFromMat(cv::Mat(3, 16, CV_8UC1), "SIFT-like");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("SIFT-like"), std::string::npos);
  EXPECT_TRUE(descriptorsFromMat(cv::Mat(), "empty")->empty());
}

TEST(KMajority, MajorityIsBitwiseWithTiesToOne) {
  const std::vector<Descriptor> all = {withBits({0, 1}), withBits({0, 2}), withBits({0, 1, 3}),
                                       withBits({5})};
  const std::vector<uint32_t> three = {0, 1, 2};
  EXPECT_EQ(bitwiseMajority(all, three), withBits({0, 1}));  // bit 0: 3/3, bit 1: 2/3
  const std::vector<uint32_t> two = {0, 3};
  EXPECT_EQ(bitwiseMajority(all, two), withBits({0, 1, 5}));  // each 1 of 2: ties give 1
}

TEST(KMajority, RecoversWellSeparatedClusters) {
  // Five random centres, 40 copies of each with 10 bits flipped: the majority of the copies
  // is the centre itself, and every copy lies closer to its own centre (random centres are
  // ~128 bits apart).
  SplitMix64 rng(42);
  std::vector<Descriptor> centres;
  std::vector<Descriptor> all;
  for (int c = 0; c < 5; ++c) {
    centres.push_back(randomDescriptor(rng));
    for (int i = 0; i < 40; ++i) all.push_back(flipBits(centres.back(), 10, rng));
  }
  std::vector<uint32_t> members(all.size());
  std::iota(members.begin(), members.end(), 0u);
  SplitMix64 seed_rng(7);
  const KMajorityResult r = kMajority(all, members, 5, 20, seed_rng);
  ASSERT_EQ(r.centres.size(), 5u);
  EXPECT_TRUE(r.converged);
  for (size_t j = 0; j < 5; ++j) {
    ASSERT_EQ(r.members[j].size(), 40u);
    const uint32_t truth = r.members[j][0] / 40;
    for (uint32_t m : r.members[j]) EXPECT_EQ(m / 40, truth);
    EXPECT_EQ(r.centres[j], centres[truth]);
  }
}

TEST(KMajority, FewerDistinctDescriptorsThanKGiveOneClusterEach) {
  SplitMix64 rng(3);
  const Descriptor a = randomDescriptor(rng), b = randomDescriptor(rng);
  const std::vector<Descriptor> all = {a, b, a, a, b};
  const std::vector<uint32_t> members = {0, 1, 2, 3, 4};
  const KMajorityResult r = kMajority(all, members, 10, 5, rng);
  ASSERT_EQ(r.centres.size(), 2u);
  EXPECT_EQ(r.members[0].size() + r.members[1].size(), 5u);
}

// root -> {A, B}; A -> {w0, w1}; B is word 2. Built in a scrambled order on purpose.
std::vector<NodeSpec> smallTree(const Descriptor& a, const Descriptor& b, const Descriptor& w0,
                                const Descriptor& w1) {
  return {
      {-1, {}, 0.0, -1},  // root
      {4, w1, 0.5, 1},    // child of A
      {0, b, 2.0, 2},     // B, a word at depth 1
      {4, w0, 1.0, 0},    // child of A
      {0, a, 0.0, -1},    // A
  };
}

TEST(Vocabulary, CreateStoresBreadthFirstAndQuantisesToTheNearestChild) {
  const Descriptor a = withBits({0, 1, 2, 3}), b = withBits({100, 101, 102, 103});
  const Descriptor w0 = withBits({0, 1, 2, 3, 4}), w1 = withBits({0, 1, 2, 3, 200, 201});
  auto v = Vocabulary::create(2, 2, smallTree(a, b, w0, w1), "small");
  ASSERT_TRUE(v.ok()) << v.error().message;
  EXPECT_EQ(v->numNodes(), 5u);
  EXPECT_EQ(v->numWords(), 3u);
  // Breadth first: root, then B and A in the order they were listed, then A's children.
  EXPECT_EQ(v->numChildren(0), 2u);
  EXPECT_EQ(v->descriptor(v->firstChild(0)), b);
  EXPECT_EQ(v->depth(v->nodeOfWord(2)), 1);
  EXPECT_EQ(v->depth(v->nodeOfWord(0)), 2);
  EXPECT_EQ(v->wordsPerDepth(), (std::vector<size_t>{0, 1, 2}));
  EXPECT_EQ(v->wordOf(withBits({0, 1, 2, 3, 4, 5})), 0u);
  EXPECT_EQ(v->wordOf(withBits({0, 1, 2, 200, 201})), 1u);
  EXPECT_EQ(v->wordOf(withBits({100, 101, 102})), 2u);
  // A tie at the top (2 bits from A, 2 from B) goes to the first child, B.
  EXPECT_EQ(v->wordOf(withBits({0, 1, 100, 101})), 2u);
}

TEST(Vocabulary, TransformGivesL1NormalisedTfIdf) {
  const Descriptor a = withBits({0, 1, 2, 3}), b = withBits({100, 101, 102, 103});
  const Descriptor w0 = withBits({0, 1, 2, 3, 4}), w1 = withBits({0, 1, 2, 3, 200, 201});
  auto v = Vocabulary::create(2, 2, smallTree(a, b, w0, w1), "small");
  ASSERT_TRUE(v.ok());
  // Two features on word 0 (idf 1), one on word 1 (idf 0.5), one on word 2 (idf 2):
  // tf-idf 2*1, 1*0.5, 1*2 -> divided by their sum 4.5.
  const std::vector<Descriptor> f = {w0, w0, w1, b};
  FeatureVector direct;
  BowVector bow;
  v->transform(f, 1, &bow, &direct);
  ASSERT_EQ(bow.size(), 3u);
  EXPECT_FLOAT_EQ(bow[0].weight, 2.0f / 4.5f);
  EXPECT_FLOAT_EQ(bow[1].weight, 0.5f / 4.5f);
  EXPECT_FLOAT_EQ(bow[2].weight, 2.0f / 4.5f);
  EXPECT_TRUE(isWellFormed(bow));
  // Direct index at depth 1: features 0-2 under A, feature 3 under B (a word at depth 1).
  ASSERT_EQ(direct.size(), 2u);
  for (const NodeFeatures& g : direct) {
    if (v->isWord(g.node)) {
      EXPECT_EQ(g.features, (std::vector<uint32_t>{3}));
    } else {
      EXPECT_EQ(g.features, (std::vector<uint32_t>{0, 1, 2}));
    }
  }
  // At depth 2 the groups are the words themselves.
  v->transform(f, 2, nullptr, &direct);
  EXPECT_EQ(direct.size(), 3u);
}

TEST(Vocabulary, ZeroWeightWordsAreLeftOutOfVectors) {
  const Descriptor a = withBits({0, 1, 2, 3}), b = withBits({100, 101, 102, 103});
  const Descriptor w0 = withBits({0, 1, 2, 3, 4}), w1 = withBits({0, 1, 2, 3, 200, 201});
  auto nodes = smallTree(a, b, w0, w1);
  nodes[2].weight = 0.0;  // B: seen in every training image
  auto v = Vocabulary::create(2, 2, nodes, "small");
  ASSERT_TRUE(v.ok());
  const std::vector<Descriptor> only_b = {b, b};
  EXPECT_TRUE(v->transform(only_b).empty());
  const std::vector<Descriptor> mixed = {b, w0};
  const BowVector bow = v->transform(mixed);
  ASSERT_EQ(bow.size(), 1u);
  EXPECT_FLOAT_EQ(bow[0].weight, 1.0f);
}

TEST(Vocabulary, CreateRejectsBrokenTreesNamingTheProblem) {
  const Descriptor d = withBits({1});
  auto expectError = [](std::vector<NodeSpec> nodes, int k, int levels, const std::string& part) {
    auto v = Vocabulary::create(k, levels, std::move(nodes), "broken.voc");
    ASSERT_FALSE(v.ok()) << "expected an error containing '" << part << "'";
    EXPECT_NE(v.error().message.find("broken.voc"), std::string::npos) << v.error().message;
    EXPECT_NE(v.error().message.find(part), std::string::npos) << v.error().message;
  };
  const NodeSpec root{-1, {}, 0.0, -1};
  expectError({root, {0, d, 1.0, 0}, {0, d, 1.0, 1}, {0, d, 1.0, 2}}, 2, 1, "more than k");
  expectError({root, {0, d, 0.0, -1}, {1, d, 1.0, 0}}, 2, 1, "deeper than L");
  expectError({root, {0, d, 1.0, -1}}, 2, 1, "leaf without a word");
  expectError({root, {0, d, 1.0, 0}, {0, d, 1.0, 0}}, 2, 1, "used by two nodes");
  expectError({root, {0, d, 1.0, 0}, {0, d, 1.0, 5}}, 2, 1, "word id 5");
  expectError({root, {0, d, -1.0, 0}}, 2, 1, "weight");
  expectError({root, {0, d, NAN, 0}}, 2, 1, "weight");
  expectError({root, {0, d, 1.0, 0}, {3, d, 0.0, -1}, {2, d, 1.0, 1}}, 2, 3, "cycle");
  expectError({root, {7, d, 1.0, 0}}, 2, 1, "parent 7");
  expectError({root, {0, d, 1.0, 0}}, 1, 1, "branching");
  expectError({{0, d, 0.0, -1}, {0, d, 1.0, 0}}, 2, 1, "root");
}

TEST(BowVector, L1ScoreIsOneForEqualZeroForDisjointAndSymmetric) {
  const BowVector a = {{1, 0.5f}, {4, 0.25f}, {9, 0.25f}};
  const BowVector b = {{1, 0.25f}, {5, 0.5f}, {9, 0.25f}};
  const BowVector c = {{2, 1.0f}};
  EXPECT_DOUBLE_EQ(l1Score(a, a), 1.0);
  EXPECT_DOUBLE_EQ(l1Score(a, c), 0.0);
  // 1 - 0.5 * (|0.5-0.25| + 0.25 + 0.5 + 0) = 1 - 0.5 = 0.5 (T-RO 2012, eq. 2).
  EXPECT_DOUBLE_EQ(l1Score(a, b), 0.5);
  EXPECT_DOUBLE_EQ(l1Score(b, a), 0.5);
  EXPECT_FALSE(isWellFormed({{2, 0.5f}, {1, 0.5f}}));
  EXPECT_FALSE(isWellFormed({{1, 0.5f}, {1, 0.5f}}));
  EXPECT_FALSE(isWellFormed({{1, 0.0f}}));
}

// Images of "places": each place has 60 characteristic descriptors; an image of a place shows
// them with a few bits of noise.
std::vector<std::vector<Descriptor>> syntheticImages(int places, int images_per_place,
                                                     uint64_t seed) {
  SplitMix64 rng(seed);
  std::vector<std::vector<Descriptor>> prototypes(static_cast<size_t>(places));
  for (auto& p : prototypes) {
    for (int i = 0; i < 60; ++i) p.push_back(randomDescriptor(rng));
  }
  std::vector<std::vector<Descriptor>> images;
  for (int k = 0; k < images_per_place; ++k) {
    for (const auto& p : prototypes) {
      std::vector<Descriptor> image;
      for (const Descriptor& d : p) image.push_back(flipBits(d, 8, rng));
      images.push_back(std::move(image));
    }
  }
  return images;
}

TEST(Training, IsDeterministicForASeedAndGivesIdfWeights) {
  const auto images = syntheticImages(8, 3, 11);
  TrainingOptions o;
  o.branching = 4;
  o.levels = 3;
  TrainingSummary s;
  auto v1 = trainVocabulary(images, o, &s);
  ASSERT_TRUE(v1.ok()) << v1.error().message;
  auto v2 = trainVocabulary(images, o);
  ASSERT_TRUE(v2.ok());
  EXPECT_EQ(v1->fingerprint(), v2->fingerprint());
  o.seed = 2;
  EXPECT_NE(trainVocabulary(images, o)->fingerprint(), v1->fingerprint());
  EXPECT_EQ(s.images, 24u);
  EXPECT_EQ(s.descriptors, 24u * 60u);
  EXPECT_EQ(s.words, v1->numWords());
  EXPECT_FALSE(s.message.empty());
  // Every weight is ln(24 / n) for an integer 1 <= n <= 24 of images holding the word.
  for (uint32_t w = 0; w < v1->numWords(); ++w) {
    const double n = 24.0 / std::exp(v1->weight(w));
    EXPECT_NEAR(n, std::round(n), 1e-9) << "word " << w;
    EXPECT_GE(std::round(n), 1.0);
  }
}

TEST(Training, ImagesOfOnePlaceScoreHigherThanImagesOfOthers) {
  const int places = 10;
  const auto images = syntheticImages(places, 2, 21);  // image i and i + places: same place
  TrainingOptions o;
  o.branching = 6;
  o.levels = 3;
  auto v = trainVocabulary(images, o);
  ASSERT_TRUE(v.ok());
  const auto fresh = syntheticImages(places, 1, 21);  // same prototypes, new noise
  for (int p = 0; p < places; ++p) {
    const BowVector q = v->transform(fresh[static_cast<size_t>(p)]);
    EXPECT_NEAR(l1Score(q, q), 1.0, 1e-6);
    const double same = l1Score(q, v->transform(images[static_cast<size_t>(p)]));
    for (int other = 0; other < places; ++other) {
      if (other == p) continue;
      EXPECT_GT(same, l1Score(q, v->transform(images[static_cast<size_t>(other)])) + 0.2)
          << "place " << p << " vs " << other;
    }
  }
}

TEST(Training, RejectsNoDataAndBadOptions) {
  EXPECT_FALSE(trainVocabulary({}, {}).ok());
  EXPECT_FALSE(trainVocabulary({{}, {}}, {}).ok());
  TrainingOptions o;
  o.branching = 1;
  auto r = trainVocabulary(syntheticImages(2, 1, 1), o);
  ASSERT_FALSE(r.ok());
  // Named by its option key (evermap-vocab-train --k), with the range.
  EXPECT_NE(r.error().message.find("option k: 1 is outside [2, 64]"), std::string::npos)
      << r.error().message;
  SplitMix64 rng(1);
  const Descriptor d = randomDescriptor(rng);
  auto same = trainVocabulary({{d, d}, {d}}, {});
  ASSERT_FALSE(same.ok());
  EXPECT_NE(same.error().message.find("identical"), std::string::npos);
}

}  // namespace
}  // namespace evermap::bow
