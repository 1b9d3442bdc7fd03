// tools/datasets/euroc: the readers against the real EuRoC excerpt and against broken files.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "scratch_dir.h"
#include "test_data.h"
#include "tools/datasets/euroc.h"

namespace evermap::datasets {
namespace {

TEST(EurocReaders, ReadTheRealExcerptCompletely) {
  EVERMAP_REQUIRE_DATA(dir, "euroc-v101-micro");
  const auto imu = readEurocImu(dir / "mav0/imu0/data.csv");
  ASSERT_TRUE(imu.ok()) << imu.error().message;
  EXPECT_EQ(imu->size(), 29120u);
  EXPECT_EQ(imu->front().utime, 1403715273262143LL);  // 1403715273262142976 ns, rounded
  EXPECT_NEAR(imu->front().accel_m_s2.x(), 9.0874956666666655, 1e-12);

  const auto cam1 = readEurocImages(dir / "mav0/cam1/data.csv");
  ASSERT_TRUE(cam1.ok()) << cam1.error().message;
  EXPECT_EQ(cam1->size(), 99u);  // 4 more rows than images on disk (SOURCE.txt)
  EXPECT_EQ(cam1->front().filename, "1403715273262142976.png");

  const auto gt = readEurocGroundTruth(dir / "groundtruth_openvins/V1_01_easy.csv");
  ASSERT_TRUE(gt.ok()) << gt.error().message;
  EXPECT_EQ(gt->size(), 2895u);
  EXPECT_NEAR(gt->front().world_T_body.translation().x(), 0.878895, 1e-12);
  EXPECT_NEAR(gt->front().world_T_body.quaternion().w(), 0.069433, 1e-5);

  const auto tum = readEurocGroundTruth(dir / "groundtruth_openvins/V1_01_easy_original.txt");
  ASSERT_TRUE(tum.ok()) << tum.error().message;
  EXPECT_EQ(tum->size(), 28712u);
  EXPECT_EQ(tum->front().t_ns, 1403715274302140000LL);
}

TEST(EurocReaders, MalformedLineIsReportedWithFileAndLine) {
  const evermap::testing::ScratchDir dir;
  const auto path =
      dir.write("evermap_bad_imu.csv", "#header\n1,0,0,0,0,0,9.81\n2,0,0,zero,0,0,9.81\n");
  const auto imu = readEurocImu(path);
  ASSERT_FALSE(imu.ok());
  EXPECT_NE(imu.error().message.find("evermap_bad_imu.csv:3"), std::string::npos)
      << imu.error().message;
}

TEST(EurocReaders, MissingFileIsAnErrorNamingIt) {
  const auto r = readEurocImages("/nonexistent/cam0/data.csv");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("/nonexistent/cam0/data.csv"), std::string::npos);
}

TEST(EurocReaders, SecondsAreReadToTheNanosecond) {
  int64_t ns = 0;
  ASSERT_TRUE(parseSecondsToNs("1403715274.30214", &ns));
  EXPECT_EQ(ns, 1403715274302140000LL);
  ASSERT_TRUE(parseSecondsToNs("-0.5", &ns));
  EXPECT_EQ(ns, -500000000LL);
  ASSERT_TRUE(parseSecondsToNs("12", &ns));
  EXPECT_EQ(ns, 12000000000LL);
  ASSERT_TRUE(parseSecondsToNs("1.038752e-01", &ns));  // KITTI times.txt style
  EXPECT_EQ(ns, 103875200LL);
  EXPECT_FALSE(parseSecondsToNs("", &ns));
  EXPECT_FALSE(parseSecondsToNs("1.2.3", &ns));
  EXPECT_FALSE(parseSecondsToNs("abc", &ns));
  EXPECT_FALSE(parseSecondsToNs("nan", &ns));
}

TEST(EurocReaders, TumLayoutCanBeForcedWhateverTheExtension) {
  const evermap::testing::ScratchDir dir;
  const auto path =
      dir.write("evermap_gt_forced.tum",
                "# t x y z qx qy qz qw\n\t1.5 1 2 3 0 0 0 1\n2.5 1 2 4 0 0 0.7071068 0.7071068\n");
  const auto gt = readEurocGroundTruth(path, PoseFileLayout::kTum);
  ASSERT_TRUE(gt.ok()) << gt.error().message;
  ASSERT_EQ(gt->size(), 2u);
  EXPECT_EQ(gt->at(0).t_ns, 1500000000LL);
  EXPECT_NEAR(gt->at(1).world_T_body.translation().z(), 4.0, 1e-12);
  EXPECT_NEAR(gt->at(1).world_T_body.quaternion().z(), std::sqrt(0.5), 1e-6);
}

TEST(EurocReaders, BadGroundTruthLinesNameFileAndLine) {
  const evermap::testing::ScratchDir dir;
  const auto path = dir / "evermap_gt_bad.txt";
  const auto expectError = [&](const std::string& body, const std::string& what) {
    {
      std::ofstream f(path);
      f << body;
    }
    const auto gt = readEurocGroundTruth(path);
    ASSERT_FALSE(gt.ok()) << body;
    EXPECT_NE(gt.error().message.find("evermap_gt_bad.txt:2"), std::string::npos)
        << gt.error().message;
    EXPECT_NE(gt.error().message.find(what), std::string::npos) << gt.error().message;
  };
  expectError("0 0 0 0 0 0 0 1\n1 0 0 0 0 0 1\n", "expected 8 numbers");
  expectError("0 0 0 0 0 0 0 1\n1 0 0 0 0 0 0 1 5\n", "expected 8 numbers");
  expectError("0 0 0 0 0 0 0 1\n1 nan 0 0 0 0 0 1\n", "non-finite");
  expectError("0 0 0 0 0 0 0 1\n1 0 0 0 0 0 0 2\n", "quaternion norm");
  expectError("0 0 0 0 0 0 0 1\n1x 0 0 0 0 0 0 1\n", "");
}

}  // namespace
}  // namespace evermap::datasets
