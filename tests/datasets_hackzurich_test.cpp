// Readers used by the imu/elevator runner: the HackZurich phone sessions and IMU LCM logs.

#include <cstdio>
#include <filesystem>
#include <fstream>

#include <unistd.h>

#include <gtest/gtest.h>

#include "test_data.h"
#include "tools/datasets/hackzurich.h"
#include "tools/imu-elevator-run/imu_log.h"

namespace evermap {
namespace {

std::filesystem::path tempDir(const std::string& name) {
  const auto d = std::filesystem::temp_directory_path() /
                 ("evermap_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::create_directories(d);
  return d;
}

TEST(HackzurichReader, EpisodesWithNumberOrStringTimesAreRead) {
  const auto dir = tempDir("episodes");
  std::ofstream(dir / "e.json") << R"([{"start_time": 1474103760, "end_time": "1474103925",
      "label": "ride", "description": "up \"and\" down"}])";
  const auto e = datasets::readHackzurichEpisodes(dir / "e.json");
  ASSERT_TRUE(e.ok()) << e.error().message;
  ASSERT_EQ(e->size(), 1u);
  EXPECT_EQ((*e)[0].start_ns, 1474103760LL * 1000000000LL);
  EXPECT_EQ((*e)[0].end_ns, 1474103925LL * 1000000000LL);
  EXPECT_EQ((*e)[0].description, "up \"and\" down");
  std::filesystem::remove_all(dir);
}

TEST(HackzurichReader, AMissingFileOrABadLineIsAnErrorNamingIt) {
  const auto dir = tempDir("bad");
  auto r = datasets::readHackzurichSession(dir, 1);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("session1_accelerometer.csv"), std::string::npos);
  std::ofstream(dir / "session1_accelerometer.csv") << "unix_time_s,date_iso,x,y,z\n"
                                                       "1.0,d,0,0,-1\n2.0,d,zero,0,-1\n";
  r = datasets::readHackzurichSession(dir, 1);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("session1_accelerometer.csv:3"), std::string::npos)
      << r.error().message;
  std::filesystem::remove_all(dir);
}

TEST(HackzurichReader, SessionOneHasPhoneSamplesInSpecificForce) {
  EVERMAP_REQUIRE_DATA(dir, "elevator-imu-baro-hackzurich");
  const auto s = datasets::readHackzurichSession(dir, 1);
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(s->accelerometer_rows, 42117);
  EXPECT_GT(s->imu.size(), 40000u);
  EXPECT_EQ(s->episodes.size(), 2u);
  EXPECT_GT(s->barometer.size(), 2000u);
  // The phone starts lying face up: +g on z once the iOS sign is undone.
  EXPECT_NEAR(s->imu.front().accel_m_s2.z(), 9.74, 0.1);
}

TEST(ImuLog, WrittenSamplesReadBackAndABadFileIsNamed) {
  const auto dir = tempDir("imulog");
  std::vector<imu::ImuSample> in(3);
  for (int i = 0; i < 3; ++i) {
    in[i].utime = 1000 + i * 5000;
    in[i].gyro_rad_s = Eigen::Vector3d(0.1 * i, 0.2, 0.3);
    in[i].accel_m_s2 = Eigen::Vector3d(0, 0.5 * i, 9.8);
  }
  const std::string file = (dir / "imu.lcm").string();
  ASSERT_TRUE(imu::writeImuLog(file, "IMU", in).ok());
  const auto out = imu::readImuLog(file, "IMU");
  ASSERT_TRUE(out.ok()) << out.error().message;
  ASSERT_EQ(out->samples.size(), 3u);
  EXPECT_EQ(out->samples[2].utime, in[2].utime);
  EXPECT_EQ(out->samples[2].accel_m_s2, in[2].accel_m_s2);
  EXPECT_EQ(out->samples[1].gyro_rad_s, in[1].gyro_rad_s);
  EXPECT_TRUE(imu::readImuLog(file, "OTHER")->samples.empty());
  const auto missing = imu::readImuLog((dir / "nope.lcm").string(), "IMU");
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().message.find("nope.lcm"), std::string::npos);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace evermap
