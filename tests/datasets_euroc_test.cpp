// core/datasets/euroc: the readers against the real EuRoC excerpt and against broken files.
#include <gtest/gtest.h>

#include <fstream>

#include "core/datasets/euroc.h"
#include "test_data.h"

namespace evermap::datasets {
namespace {

TEST(EurocReaders, ReadTheRealExcerptCompletely) {
  EVERMAP_REQUIRE_DATA(dir, "euroc-v101-micro");
  const auto imu = readEurocImu(dir / "mav0/imu0/data.csv");
  ASSERT_TRUE(imu.ok()) << imu.error().message;
  EXPECT_EQ(imu->size(), 29120u);
  EXPECT_EQ(imu->front().t_ns, 1403715273262142976LL);
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
  const auto path = std::filesystem::temp_directory_path() / "evermap_bad_imu.csv";
  {
    std::ofstream f(path);
    f << "#header\n1,0,0,0,0,0,9.81\n2,0,0,zero,0,0,9.81\n";
  }
  const auto imu = readEurocImu(path);
  ASSERT_FALSE(imu.ok());
  EXPECT_NE(imu.error().message.find("evermap_bad_imu.csv:3"), std::string::npos)
      << imu.error().message;
  std::filesystem::remove(path);
}

TEST(EurocReaders, MissingFileIsAnErrorNamingIt) {
  const auto r = readEurocImages("/nonexistent/cam0/data.csv");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("/nonexistent/cam0/data.csv"), std::string::npos);
}

}  // namespace
}  // namespace evermap::datasets
