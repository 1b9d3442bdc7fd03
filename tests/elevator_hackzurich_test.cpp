// The elevator tracker on real phone data: HackZurich 2016 sessions 1 and 2 (iPhone,
// 10 Hz, in a hand or a pocket; ../shared/data/elevator-imu-baro-hackzurich). The labelled
// episodes say what was done, not when each ride happened; the rides below were read off the
// barometer (its altitude moving faster than 0.35 m/s inside an episode; unix seconds, the
// pressure altitude lags the motion by 2-4 s). The barometer also gives each ride's height.
//
// Asserted, with the gyroscope and with it zeroed (accelerometer-only mode): every labelled
// ride is found once, its displacement within 1.5 m or 20 % of the
// barometric change (whichever is larger); inside the episodes no other ride is reported;
// during the stairs segment no floor event at all.
//
// Outside the episodes. The sessions are 12 h (session 1) and 1 h (session 2) of a phone
// carried around a hackathon building; the two episodes of each are the only labels, and
// the barometer shows that the phone rode elevators between them too. A ride reported there
// is accepted only when the barometer confirms an elevator ride at that moment: its height
// change matches the displacement (same tolerance as the labelled rides, and over 2 m), and
// the altitude moved at elevator speed (>= kElevatorRate over 2-6 s; the labelled rides:
// 0.85-1.6 m/s; walking the stairs down: 0.47 m/s, asserted below). Any other ride outside
// is a false positive and fails the test. A ride start given up later (a FLOOR start, then
// an end on the floor left) is held to the same: elevator-speed motion of the barometer.

#include <cmath>
#include <cstdio>
#include <string>
#include <tuple>
#include <vector>

#include <gtest/gtest.h>

#include "test_data.h"
#include "tools/datasets/hackzurich.h"
#include "tools/imu-elevator-run/offline_run.h"
#include "tools/imu-elevator-run/ride_report.h"

namespace evermap::elevator {
namespace {

struct LabelledRide {
  double baro_start_s, baro_end_s;  // unix time
};

struct SessionTruth {
  int session;
  std::vector<LabelledRide> rides;
  std::vector<std::pair<double, double>> stairs;  // unix time windows with no ride
};

const std::vector<SessionTruth>& truths() {
  static const std::vector<SessionTruth> t = {
      {1,
       {{1474103777.1, 1474103789.8},   // getting_in_and_out: up 15.5 m
        {1474103851.5, 1474103857.1},   //   down 6.2 m
        {1474103917.5, 1474103920.3},   //   down 3.2 m
        {1474104290.9, 1474104299.3}},  // walk_and_ride: down 10 m
       {}},
      {2,
       {{1474121118.7, 1474121122.9},    // elevator_up_and_stairs_down: up 3.3 m (a stop)
        {1474121132.7, 1474121138.3},    //   up 5.7 m
        {1474122869.5, 1474122877.9},    // riding_the_elevator_is_fun: up 9.6 m
        {1474122897.6, 1474122901.8},    //   up 3.0 m
        {1474122915.8, 1474122921.5},    //   up 6.0 m
        {1474122935.5, 1474122945.3},    //   down 12.1 m
        {1474122966.4, 1474122972.0},    //   up 5.8 m
        {1474122987.4, 1474122993.0},    //   down 5.9 m
        {1474123005.7, 1474123012.7}},   //   down 6.7 m
       {{1474121160.0, 1474121215.0}}},  // walking the stairs down, 10 m
  };
  return t;
}

double unixSeconds(int64_t utime) { return 1e-6 * static_cast<double>(utime); }

// Barometric altitude speed that stairs do not reach (m/s).
constexpr double kElevatorRate = 0.7;

// (session index, gyroscope zeroed): the same rides must be found accelerometer-only.
class ElevatorHackzurich : public ::testing::TestWithParam<std::tuple<int, bool>> {};

TEST_P(ElevatorHackzurich, EveryLabelledRideIsFoundWithTheBarometricHeight) {
  EVERMAP_REQUIRE_DATA(dir, "elevator-imu-baro-hackzurich");
  const SessionTruth& truth = truths()[std::get<0>(GetParam())];
  const bool zero_gyro = std::get<1>(GetParam());
  const auto session = datasets::readHackzurichSession(dir, truth.session);
  ASSERT_TRUE(session.ok()) << session.error().message;
  ASSERT_EQ(session->episodes.size(), 2u);
  std::vector<imu::ImuSample> samples = session->imu;
  if (zero_gyro) {
    for (imu::ImuSample& s : samples) s.gyro_rad_s.setZero();
  }
  const OfflineRun run = runImuElevator(samples, {}, {});
  const std::vector<RideRow> rows =
      ridesWithReference(run.rides, session->barometer, session->episodes);
  EXPECT_EQ(run.attitude_counts.accel_only, zero_gyro);
  EXPECT_TRUE(run.rejected.empty());
  std::printf("session %d%s (%s)\n%s", truth.session, zero_gyro ? ", gyroscope zeroed" : "",
              run.counts.summary().c_str(), formatRideTable(rows, samples.front().utime).c_str());
  for (const auto& a : run.abandoned) {
    std::printf("  abandoned start at unix %.1f: %s\n", unixSeconds(a.start_utime),
                a.reason.c_str());
  }

  auto inEpisode = [&](double t0, double t1) {
    for (const auto& e : session->episodes) {
      if (t0 < 1e-9 * e.end_ns && t1 > 1e-9 * e.start_ns) return true;
    }
    return false;
  };
  std::vector<int> hits(rows.size(), 0);
  for (const LabelledRide& l : truth.rides) {
    int found = 0;
    for (size_t i = 0; i < rows.size(); ++i) {
      const double s = unixSeconds(rows[i].ride.start_utime),
                   e = unixSeconds(rows[i].ride.end_utime);
      if (s < l.baro_end_s + 2.0 && e > l.baro_start_s - 8.0) {
        ++found;
        ++hits[i];
        ASSERT_TRUE(rows[i].has_baro);
        const double tolerance = std::max(1.5, 0.2 * std::abs(rows[i].baro_change_m));
        EXPECT_NEAR(rows[i].ride.displacement_m, rows[i].baro_change_m, tolerance)
            << "ride at unix " << s;
      }
    }
    EXPECT_EQ(found, 1) << "labelled ride at unix " << l.baro_start_s;
  }
  for (size_t i = 0; i < rows.size(); ++i) {
    const double s = unixSeconds(rows[i].ride.start_utime), e = unixSeconds(rows[i].ride.end_utime);
    if (hits[i] > 0) continue;
    EXPECT_FALSE(inEpisode(s, e)) << "unlabelled ride inside an episode at unix " << s;
    // Outside the episodes: a real (unlabelled) ride, or an error.
    ASSERT_TRUE(rows[i].has_baro) << "ride at unix " << s << " has no barometer to confirm it";
    const double tolerance = std::max(1.5, 0.2 * std::abs(rows[i].baro_change_m));
    EXPECT_NEAR(rows[i].ride.displacement_m, rows[i].baro_change_m, tolerance)
        << "ride outside the episodes at unix " << s << " not confirmed by the barometer";
    EXPECT_GT(std::abs(rows[i].baro_change_m), 2.0);
    EXPECT_GE(rows[i].baro_peak_rate_m_s, kElevatorRate)
        << "ride outside the episodes at unix " << s
        << ": the barometer moved too slowly for an elevator";
  }
  for (const auto& [a, b] : truth.stairs) {
    double rate = 0;
    ASSERT_TRUE(baroPeakRate(session->barometer, static_cast<int64_t>(a * 1e6),
                             static_cast<int64_t>(b * 1e6), &rate));
    std::printf("  stairs unix %.0f..%.0f: barometer at most %.2f m/s\n", a, b, rate);
    EXPECT_LT(rate, kElevatorRate) << "the elevator-speed criterion must tell stairs apart";
    for (const FloorEvent& ev : run.rideEvents()) {
      EXPECT_FALSE(unixSeconds(ev.utime) > a && unixSeconds(ev.utime) < b)
          << "ride event on the stairs at unix " << unixSeconds(ev.utime);
    }
  }
  // No ride attempt inside a labelled episode other than the rides themselves.
  for (const auto& ab : run.abandoned) {
    EXPECT_FALSE(inEpisode(unixSeconds(ab.start_utime), unixSeconds(ab.abandon_utime)))
        << "abandoned ride start inside an episode at unix " << unixSeconds(ab.start_utime);
    double rate = 0;
    ASSERT_TRUE(baroPeakRate(session->barometer, ab.start_utime - 5'000'000,
                             ab.abandon_utime + 15'000'000, &rate));
    std::printf("  abandoned start at unix %.1f: barometer at most %.2f m/s\n",
                unixSeconds(ab.start_utime), rate);
    EXPECT_GE(rate, kElevatorRate) << "abandoned ride start at unix " << unixSeconds(ab.start_utime)
                                   << " with no elevator motion in the barometer";
  }
}

INSTANTIATE_TEST_SUITE_P(Sessions, ElevatorHackzurich,
                         ::testing::Combine(::testing::Values(0, 1), ::testing::Bool()));

}  // namespace
}  // namespace evermap::elevator
