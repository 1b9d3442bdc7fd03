// tools/datasets/kitti: calib.txt in both forms, times and poses, against the real files and
// broken ones.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "scratch_dir.h"
#include "test_data.h"
#include "tools/datasets/kitti.h"

namespace evermap::datasets {
namespace {

namespace fs = std::filesystem;

fs::path writeTemp(const testing::ScratchDir& dir, const std::string& name,
                   const std::string& text) {
  std::ofstream(dir / name) << text;
  return dir / name;
}

void expectError(const auto& r, const std::string& needle) {
  ASSERT_FALSE(r.ok()) << "accepted; wanted: " << needle;
  EXPECT_NE(r.error().message.find(needle), std::string::npos)
      << "got: " << r.error().message << "\nwanted: " << needle;
}

TEST(KittiCalib, LabelledFileGivesTheRectifiedPairOfSequence07) {
  EVERMAP_REQUIRE_DATA(dir, "kitti07-mono-160");
  const auto p = readKittiCalib(dir / "calib.txt");
  ASSERT_TRUE(p.ok()) << p.error().message;
  EXPECT_DOUBLE_EQ(p->P0(0, 0), 707.0912);
  EXPECT_DOUBLE_EQ(p->P1(0, 3), -379.8145);
  const auto c = kittiStereoCalibration(*p, 1226, 370);
  ASSERT_TRUE(c.ok()) << c.error().message;
  EXPECT_TRUE(c->rectified);
  const auto cam = core::rectifiedStereoCamera(*c);
  ASSERT_TRUE(cam.ok()) << cam.error().message;
  EXPECT_NEAR(cam->baselineM(), 379.8145 / 707.0912, 1e-12);  // 0.537 m
  EXPECT_DOUBLE_EQ(cam->cx(), 601.8873);
  EXPECT_DOUBLE_EQ(cam->cy(), 183.1104);
  EXPECT_EQ(cam->width(), 1226);
}

TEST(KittiCalib, UnlabelledFileGivesTheRectifiedPairOfSequences00To02) {
  EVERMAP_REQUIRE_DATA(dir, "kitti-mono-snippet");
  const auto p = readKittiCalib(dir / "calib.txt");
  ASSERT_TRUE(p.ok()) << p.error().message;
  const auto cam = core::rectifiedStereoCamera(*kittiStereoCalibration(*p, 1241, 376));
  ASSERT_TRUE(cam.ok()) << cam.error().message;
  EXPECT_NEAR(cam->baselineM(), 0.5371657, 1e-6);
  EXPECT_DOUBLE_EQ(cam->fx(), 718.856);
  EXPECT_DOUBLE_EQ(cam->cx(), 607.1928);
}

TEST(KittiCalib, BrokenOrInconsistentFilesAreRefused) {
  const testing::ScratchDir scratch;
  const std::string p0 = "700 0 600 0 0 700 180 0 0 0 1 0";
  expectError(readKittiCalib("/nonexistent/calib.txt"), "/nonexistent/calib.txt: cannot open");
  expectError(readKittiCalib(writeTemp(scratch, "one.txt", p0 + "\n")), "needs P0 and P1");
  expectError(readKittiCalib(writeTemp(scratch, "short.txt", "P0: 1 2 3\nP1: " + p0 + "\n")),
              "short.txt:1: expected 12 numbers");
  expectError(readKittiCalib(writeTemp(scratch, "word.txt",
                                       "P0: " + p0 + "\nP1: 700 0 600 x 0 700 180 0 0 0 1 0\n")),
              "word.txt:2: expected 12 numbers");

  const auto calib = [&](const std::string& p1) {
    const auto p = readKittiCalib(writeTemp(scratch, "c.txt", p0 + "\n" + p1 + "\n"));
    EXPECT_TRUE(p.ok());
    return kittiStereoCalibration(*p, 1226, 370, "c.txt");
  };
  EXPECT_TRUE(calib("700 0 600 -350 0 700 180 0 0 0 1 0").ok());
  expectError(calib("700 0 600 350 0 700 180 0 0 0 1 0"), "left and right swapped?");
  expectError(calib("700 0 600 0 0 700 180 0 0 0 1 0"), "baseline is 0 m");
  expectError(calib("710 0 600 -350 0 700 180 0 0 0 1 0"), "different intrinsics");
  expectError(calib("700 0 600 -350 0 700 180 5 0 0 1 0"), "offset is not along x");
  const auto p =
      readKittiCalib(writeTemp(scratch, "d.txt", p0 + "\n700 0 600 -350 0 700 180 0 0 0 1 0\n"));
  expectError(kittiStereoCalibration(*p, 1000, 100, "d.txt"),
              "principal point (600, 180) is outside the 1000x100 image");
  expectError(kittiStereoCalibration(*p, 0, 370, "d.txt"), "image size 0x370");
}

TEST(KittiTimesAndPoses, RealFilesAreReadCompletely) {
  EVERMAP_REQUIRE_DATA(dir, "kitti07-mono-160");
  const auto t = readKittiTimes(dir / "times.txt");
  ASSERT_TRUE(t.ok()) << t.error().message;
  ASSERT_EQ(t->size(), 160u);
  EXPECT_EQ((*t)[0], 0);
  EXPECT_EQ((*t)[1], 103875200);  // 1.038752e-01 s
  const auto poses = readKittiPoses(dir / "poses.txt");
  ASSERT_TRUE(poses.ok()) << poses.error().message;
  ASSERT_EQ(poses->size(), 160u);
  EXPECT_NEAR((*poses)[1].translation().z(), 9.154274e-02, 1e-12);
  EXPECT_NEAR((*poses)[1].rotationMatrix()(0, 2), -6.380358e-03, 1e-6);
}

TEST(KittiTimesAndPoses, BrokenFilesAreRefusedNamingTheLine) {
  const testing::ScratchDir scratch;
  expectError(readKittiTimes(writeTemp(scratch, "t1.txt", "0.0\n0.1\n0.1\n")),
              "t1.txt:3: time 0.1 s is not after the previous line's");
  expectError(readKittiTimes(writeTemp(scratch, "t2.txt", "0.0\nnan\n")),
              "t2.txt:2: expected one time");
  expectError(readKittiTimes(writeTemp(scratch, "t3.txt", "")), "no times");
  expectError(readKittiPoses(writeTemp(scratch, "p1.txt", "1 0 0 0 0 1 0 0 0 0 1\n")),
              "p1.txt:1: expected 12 numbers");
  expectError(readKittiPoses(writeTemp(scratch, "p2.txt",
                                       "1 0 0 0 0 1 0 0 0 0 1 0\n2 0 0 0 0 1 0 0 0 0 1 0\n")),
              "p2.txt:2: the rotation is not orthonormal");
}

}  // namespace
}  // namespace evermap::datasets
