// tools/vocab-train/image_features: natural file order, folder listing and ORB extraction with its
// error cases.
#include <gtest/gtest.h>

#include <unistd.h>

#include <fstream>

#include "test_data.h"
#include "tools/vocab-train/image_features.h"

namespace evermap::bow {
namespace {

namespace fs = std::filesystem;

TEST(NaturalOrder, ComparesDigitRunsAsNumbers) {
  EXPECT_TRUE(naturalLess("2.jpg", "10.jpg"));
  EXPECT_FALSE(naturalLess("10.jpg", "2.jpg"));
  EXPECT_TRUE(naturalLess("img_9_b", "img_10_a"));
  EXPECT_TRUE(naturalLess("000009.png", "000010.png"));
  EXPECT_TRUE(naturalLess("1.png", "01.png"));  // same value: fewer leading zeros first
  EXPECT_FALSE(naturalLess("a", "a"));
  EXPECT_TRUE(naturalLess("a", "ab"));
  EXPECT_TRUE(naturalLess("99999999999999999999999.png", "100000000000000000000000.png"));
}

TEST(ListImages, ListsImagesInNaturalOrderAndNamesBadFolders) {
  const fs::path dir = fs::temp_directory_path() / ("evermap_list_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir / "sub");
  for (const char* name : {"10.png", "2.JPG", "1.jpg", "notes.txt"})
    std::ofstream(dir / name) << "x";
  auto files = listImages(dir);
  ASSERT_TRUE(files.ok()) << files.error().message;
  ASSERT_EQ(files->size(), 3u);
  EXPECT_EQ((*files)[0].filename(), "1.jpg");
  EXPECT_EQ((*files)[1].filename(), "2.JPG");
  EXPECT_EQ((*files)[2].filename(), "10.png");
  auto empty = listImages(dir / "sub");
  ASSERT_FALSE(empty.ok());
  EXPECT_NE(empty.error().message.find("no image"), std::string::npos);
  EXPECT_FALSE(listImages(dir / "missing").ok());
  // A file that claims to be an image but is not: an error naming it.
  auto bad = extractOrbFromFile(dir / "10.png", {});
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("10.png"), std::string::npos);
  fs::remove_all(dir);
}

TEST(Orb, ExtractsUpToTheRequestedCountWithMatchingArrays) {
  EVERMAP_REQUIRE_DATA(dir, "rtabmap-lcd-samples");
  OrbOptions o;
  o.max_features = 500;
  auto f = extractOrbFromFile(dir / "samples" / "1.jpg", o);
  ASSERT_TRUE(f.ok()) << f.error().message;
  EXPECT_GT(f->keypoints.size(), 300u);
  EXPECT_LE(f->keypoints.size(), 500u);
  EXPECT_EQ(f->keypoints.size(), f->descriptors.size());
  EXPECT_EQ(f->image_size, cv::Size(512, 384));
  o.max_features = 0;
  EXPECT_FALSE(extractOrbFromFile(dir / "samples" / "1.jpg", o).ok());
}

}  // namespace
}  // namespace evermap::bow
