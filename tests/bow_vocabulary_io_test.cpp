// core/bow/vocabulary_io: evermap's binary vocabulary format (round trip, and a clear error for
// every kind of damage) and the DBoW2/DBoW3 YAML vocabularies of the shared data.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>

#include "bow_synthetic.h"
#include "core/bow/vocabulary_io.h"
#include "test_data.h"
#include "tools/vocab-train/image_features.h"
#include "tools/vocab-train/vocabulary_training.h"

namespace evermap::bow {
namespace {

namespace fs = std::filesystem;

class TempDir {
 public:
  TempDir() {
    path_ = fs::temp_directory_path() /
            ("evermap_bow_io_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) +
             "_" + ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~TempDir() { fs::remove_all(path_); }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

Vocabulary smallTrainedVocabulary() {
  SplitMix64 rng(9);
  std::vector<std::vector<Descriptor>> images(12);
  for (auto& image : images) {
    for (int i = 0; i < 50; ++i) image.push_back(testing::randomDescriptor(rng));
  }
  TrainingOptions o;
  o.branching = 5;
  o.levels = 3;
  return trainVocabulary(images, o).value();
}

std::string readBytes(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

void writeBytes(const fs::path& file, const std::string& bytes) {
  std::ofstream(file, std::ios::binary) << bytes;
}

void expectLoadError(const fs::path& file, const std::string& part) {
  auto v = loadVocabulary(file);
  ASSERT_FALSE(v.ok()) << "loaded a damaged file";
  EXPECT_NE(v.error().message.find(file.string()), std::string::npos) << v.error().message;
  EXPECT_NE(v.error().message.find(part), std::string::npos) << v.error().message;
}

TEST(VocabularyFile, RoundTripKeepsEveryNodeAndTheFingerprint) {
  TempDir dir;
  const Vocabulary v = smallTrainedVocabulary();
  const fs::path file = dir.path() / "small.evoc";
  ASSERT_TRUE(saveVocabulary(v, file).ok());
  EXPECT_EQ(fs::file_size(file), 40u + 48u * v.numNodes() + 8u);
  // Written through a temporary name: nothing else is left in the folder.
  EXPECT_EQ(std::distance(fs::directory_iterator(dir.path()), fs::directory_iterator()), 1);
  auto back = loadVocabulary(file);
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(back->fingerprint(), v.fingerprint());
  ASSERT_EQ(back->numNodes(), v.numNodes());
  for (uint32_t n = 0; n < v.numNodes(); ++n) {
    EXPECT_EQ(back->parent(n), v.parent(n));
    EXPECT_EQ(back->wordOfNode(n), v.wordOfNode(n));
    EXPECT_EQ(back->descriptor(n), v.descriptor(n));
  }
  for (uint32_t w = 0; w < v.numWords(); ++w) EXPECT_EQ(back->weight(w), v.weight(w));
  auto any = loadAnyVocabulary(file);
  ASSERT_TRUE(any.ok());
  EXPECT_EQ(any->fingerprint(), v.fingerprint());
}

TEST(VocabularyFile, DamageIsReportedWithTheFileName) {
  TempDir dir;
  const fs::path good = dir.path() / "good.evoc";
  ASSERT_TRUE(saveVocabulary(smallTrainedVocabulary(), good).ok());
  const std::string bytes = readBytes(good);

  const fs::path flipped = dir.path() / "flipped.evoc";
  std::string b = bytes;
  b[b.size() / 2] = static_cast<char>(b[b.size() / 2] ^ 0x10);
  writeBytes(flipped, b);
  expectLoadError(flipped, "checksum");

  const fs::path truncated = dir.path() / "truncated.evoc";
  writeBytes(truncated, bytes.substr(0, bytes.size() - 100));
  expectLoadError(truncated, "truncated");

  const fs::path header_only = dir.path() / "header.evoc";
  writeBytes(header_only, bytes.substr(0, 20));
  expectLoadError(header_only, "truncated");

  const fs::path magic = dir.path() / "magic.evoc";
  writeBytes(magic, "%YAML:1.0\n" + bytes);
  expectLoadError(magic, "bad magic");

  // A newer version is refused before anything else is read.
  const fs::path newer = dir.path() / "newer.evoc";
  b = bytes;
  b[8] = 2;
  writeBytes(newer, b);
  expectLoadError(newer, "version 2");

  expectLoadError(dir.path() / "missing.evoc", "no such file");
}

TEST(VocabularyFile, SavingIntoAMissingFolderFailsCleanly) {
  TempDir dir;
  const Status s = saveVocabulary(smallTrainedVocabulary(), dir.path() / "no" / "such" / "v.evoc");
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("v.evoc"), std::string::npos);
}

struct TreeShape {
  int branching = 0;
  int levels = 0;
  size_t words = 0;
  size_t nodes = 0;
};

// A DBoW vocabulary of `shape` trained on `images` images: every weight is ln(images / n),
// n = 1..images.
void expectDbowVocabulary(const Vocabulary& v, const TreeShape& shape, int images) {
  EXPECT_EQ(v.branching(), shape.branching);
  EXPECT_EQ(v.levels(), shape.levels);
  EXPECT_EQ(v.numWords(), shape.words);
  EXPECT_EQ(v.numNodes(), shape.nodes);
  for (uint32_t w = 0; w < v.numWords(); ++w) {
    const double n = images / std::exp(v.weight(w));
    EXPECT_NEAR(n, std::round(n), 1e-9) << "word " << w;
  }
}

TEST(DbowYaml, KimeraDbow2VocabularyLoadsWithItsShapeAndIdfWeights) {
  EVERMAP_REQUIRE_DATA(dir, "vocab-orb-small");
  auto v = loadDbowYaml(dir / "kimera_small_voc.yml.gz");
  ASSERT_TRUE(v.ok()) << v.error().message;
  // 781 listed nodes + the implicit root; trained on 4 images.
  expectDbowVocabulary(*v, {.branching = 9, .levels = 3, .words = 692, .nodes = 782}, 4);
}

TEST(DbowYaml, Slambook2Dbow3VocabularyLoadsWithItsShape) {
  EVERMAP_REQUIRE_DATA(dir, "vocab-orb-small");
  auto v = loadAnyVocabulary(dir / "slambook2_vocabulary.yml.gz");
  ASSERT_TRUE(v.ok()) << v.error().message;
  expectDbowVocabulary(*v, {.branching = 10, .levels = 5, .words = 4983, .nodes = 6163}, 10);
}

TEST(DbowYaml, Slambook2VocabularyFindsTheBooksLoopBetweenImages1And10) {
  EVERMAP_REQUIRE_DATA(dir, "vocab-orb-small");
  auto v = loadDbowYaml(dir / "slambook2_vocabulary.yml.gz");
  ASSERT_TRUE(v.ok());
  std::vector<BowVector> bow;
  for (int i = 1; i <= 10; ++i) {
    auto f =
        extractOrbFromFile(dir / "slambook2_ch11_tum_images" / (std::to_string(i) + ".png"), {});
    ASSERT_TRUE(f.ok()) << f.error().message;
    bow.push_back(v->transform(f->descriptors));
  }
  // Image 1's best match among the others is image 10 (the book's loop-closure example).
  size_t best = 1;
  for (size_t j = 1; j < 10; ++j) {
    if (l1Score(bow[0], bow[j]) > l1Score(bow[0], bow[best])) best = j;
  }
  EXPECT_EQ(best, 9u);
}

TEST(DbowYaml, KimeraVocabularyPairsTheEurocLoopImages) {
  EVERMAP_REQUIRE_DATA(voc, "vocab-orb-small");
  EVERMAP_REQUIRE_DATA(euroc, "euroc-v101-micro");
  auto v = loadDbowYaml(voc / "kimera_small_voc.yml.gz");
  ASSERT_TRUE(v.ok());
  std::vector<BowVector> bow;
  for (int i = 0; i < 4; ++i) {
    auto f =
        extractOrbFromFile(euroc / "lcd_pairs" / ("left_img_" + std::to_string(i) + ".png"), {});
    ASSERT_TRUE(f.ok());
    bow.push_back(v->transform(f->descriptors));
  }
  // Pairs (0, 1) and (2, 3) are true loops; the cross pairs are not.
  for (int i = 0; i < 4; ++i) {
    const int partner = i ^ 1;
    for (int other = 0; other < 4; ++other) {
      if (other == i || other == partner) continue;
      EXPECT_GT(l1Score(bow[i], bow[partner]), l1Score(bow[i], bow[other]) + 0.1);
    }
  }
}

TEST(DbowYaml, MalformedFilesGiveOneLineErrors) {
  TempDir dir;
  auto check = [&](const std::string& name, const std::string& text, const std::string& part) {
    const fs::path file = dir.path() / name;
    writeBytes(file, text);
    auto v = loadDbowYaml(file);
    ASSERT_FALSE(v.ok()) << name;
    EXPECT_NE(v.error().message.find(name), std::string::npos) << v.error().message;
    EXPECT_NE(v.error().message.find(part), std::string::npos) << v.error().message;
    EXPECT_EQ(v.error().message.find('\n'), std::string::npos) << v.error().message;
  };
  const std::string d32 = std::string(" ") + [] {
    std::string s;
    for (int i = 0; i < 32; ++i) s += std::to_string(i) + " ";
    return s;
  }();
  const std::string head = "%YAML:1.0\n---\nvocabulary:\n   k: 2\n   L: 1\n";
  check("no_voc.yml", "%YAML:1.0\n---\nfoo: 1\n", "no 'vocabulary'");
  check("tf.yml", head + "   scoringType: 0\n   weightingType: 1\n   nodes: []\n   words: []\n",
        "weightingType 1");
  check("short_desc.yml",
        head +
            "   scoringType: 0\n   weightingType: 0\n   nodes:\n"
            "      - { nodeId:1, parentId:0, weight:1., descriptor:\"1 2 3\" }\n   words: []\n",
        "3 numbers");
  check("orphan.yml",
        head +
            "   scoringType: 0\n   weightingType: 0\n   nodes:\n"
            "      - { nodeId:1, parentId:5, weight:1., descriptor:\"" +
            d32 +
            "\" }\n"
            "   words:\n      - { wordId:0, nodeId:1 }\n",
        "parentId 5");
  check("not_yaml.yml", "\x01\x02 this is not yaml: [", "");
  auto missing = loadDbowYaml(dir.path() / "missing.yml.gz");
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().message.find("no such file"), std::string::npos);
}

}  // namespace
}  // namespace evermap::bow
