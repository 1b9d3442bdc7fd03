// A fast, long ride on real data and the inputs that used to fail silently (issue 18):
// ../shared/data/elevator-android-skyscraper, one ride up a tower (~74 m at ~4 m/s, phases of
// ~5 s at ~0.9 m/s^2) recorded by an Android phone lying on the cabin floor, accelerometer
// only (Science Journal CSV with sparse rows, ~48 Hz per axis). The author's own double
// integration gives 74.3 m, 4.01 m/s, 0.93 m/s^2; there is no barometer, and the phone reads g
// 5 % high (10.32 m/s^2 at rest), so the truth is known to a few metres: 70.8 m if that is a
// scale error, 74.3 m if an offset.

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "test_data.h"
#include "tools/datasets/science_journal.h"
#include "tools/imu-elevator-run/offline_run.h"

namespace evermap::elevator {
namespace {

int64_t accounted(const datasets::ScienceJournalRecording& r) {
  return r.rows_completing_sample + r.rows_partial + r.rows_before_first_sample + r.rows_trailing +
         r.rows_linear_only + r.rows_empty;
}

TEST(ScienceJournalReader, SparseRowsMakeSamplesAndEveryRowIsCounted) {
  const std::filesystem::path file =
      std::filesystem::temp_directory_path() / "evermap_science_journal_test.csv";
  {
    std::ofstream out(file);
    out << "relative_time,LinearAccelerometerSensor,AccX,AccY,AccZ\n"
           "0,,,,9.8\n"  // z first: no sample yet
           "1,,0.1,,\n"
           "2,,,0.2,\n"         // x, y, z known: first sample at 2 ms
           "10,0.5,,,\n"        // linear acceleration only: counted, not used
           "20,,0.3,0.4,9.9\n"  // a full row: a sample
           "30,,0.5,,\n"
           "31,,0.6,,\n"      // x again before y and z: superseded
           "32,,,0.7,10.0\n"  // completes the sample at 32 ms with x = 0.6
           "40,,,,\n"         // nothing
           "50,,1.0,,\n";     // an incomplete triple at the end
  }
  const auto r = datasets::readScienceJournalCsv(file);
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_EQ(r->imu.size(), 3u);
  EXPECT_EQ(r->imu[0].utime, 2'000);
  EXPECT_DOUBLE_EQ(r->imu[0].accel_m_s2.z(), 9.8);
  EXPECT_EQ(r->imu[1].utime, 20'000);
  EXPECT_EQ(r->imu[2].utime, 32'000);
  EXPECT_DOUBLE_EQ(r->imu[2].accel_m_s2.x(), 0.6);
  EXPECT_TRUE(r->imu[2].gyro_rad_s.isZero(0.0));
  EXPECT_EQ(r->rows, 10);
  EXPECT_EQ(r->rows_linear_only, 1);
  EXPECT_EQ(r->rows_empty, 1);
  EXPECT_EQ(r->rows_trailing, 1);
  EXPECT_EQ(r->values_superseded, 1);
  EXPECT_EQ(accounted(*r), r->rows) << r->summary();

  {
    std::ofstream out(file);
    out << "relative_time,AccX,AccY,AccZ\n0,1,2,3\n5,1,x,3\n";
  }
  const auto bad = datasets::readScienceJournalCsv(file);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find(":3:"), std::string::npos) << bad.error().message;
  {
    std::ofstream out(file);
    out << "time,X,Y,Z\n0,1,2,3\n";
  }
  EXPECT_FALSE(datasets::readScienceJournalCsv(file).ok());
  std::filesystem::remove(file);
}

TEST(ElevatorSkyscraper, TheFastLongRideIsFoundAccelerometerOnly) {
  EVERMAP_REQUIRE_DATA(dir, "elevator-android-skyscraper");
  const auto rec = datasets::readScienceJournalCsv(dir / "skyscrapper_up.csv");
  ASSERT_TRUE(rec.ok()) << rec.error().message;
  std::printf("%s\n", rec->summary().c_str());
  EXPECT_EQ(accounted(*rec), rec->rows);
  EXPECT_GT(rec->imu.size(), 1700u);
  const OfflineRun run = runImuElevator(rec->imu, {}, {});
  std::printf("attitude: %s\nelevator: %s\n", run.attitude_counts.summary().c_str(),
              run.counts.summary().c_str());
  EXPECT_TRUE(run.attitude_counts.accel_only);
  ASSERT_EQ(run.rides.size(), 1u);
  const Ride& r = run.rides.front();
  std::printf(
      "ride %.1f..%.1f s: %+.2f m (sigma %.2f), peak %.2f m/s, pulses %+.2f / %+.2f m/s^2\n",
      1e-6 * static_cast<double>(r.start_utime), 1e-6 * static_cast<double>(r.end_utime),
      r.displacement_m, r.sigma_m, r.peak_speed_m_s, r.start_accel_m_s2, r.stop_accel_m_s2);
  // 70.8-74.3 m (see the top), and a few metres of the author's own uncertainty.
  EXPECT_NEAR(r.displacement_m, 73.0, 4.0);
  EXPECT_NEAR(r.peak_speed_m_s, 4.0, 0.4);
  EXPECT_EQ(r.to_floor, 1);
  EXPECT_TRUE(run.rejected.empty());
}

// The same recording as Android's gravity-removed "linear acceleration" would give it (the
// accelerometer minus a low-passed gravity, time constant 1 s): no ride, and the tracker says
// that the input is not gravity rather than reporting a +-1 m ride on the same floor.
TEST(ElevatorSkyscraper, AGravityRemovedStreamIsRefusedNotMisread) {
  EVERMAP_REQUIRE_DATA(dir, "elevator-android-skyscraper");
  const auto rec = datasets::readScienceJournalCsv(dir / "skyscrapper_up.csv");
  ASSERT_TRUE(rec.ok()) << rec.error().message;
  std::vector<imu::ImuSample> linear = rec->imu;
  Eigen::Vector3d gravity = linear.front().accel_m_s2;
  for (size_t i = 0; i < linear.size(); ++i) {
    const double dt =
        i > 0 ? 1e-6 * static_cast<double>(linear[i].utime - linear[i - 1].utime) : 0.0;
    gravity += dt / (1.0 + dt) * (linear[i].accel_m_s2 - gravity);
    linear[i].accel_m_s2 -= gravity;
  }
  const OfflineRun run = runImuElevator(linear, {}, {});
  EXPECT_TRUE(run.rides.empty());
  EXPECT_FALSE(run.gravity_plausible) << "reference " << run.gravity_m_s2;
  for (const RejectedRide& r : run.rejected) {
    EXPECT_NE(r.reason.find("gravity"), std::string::npos) << r.reason;
  }
}

}  // namespace
}  // namespace evermap::elevator
