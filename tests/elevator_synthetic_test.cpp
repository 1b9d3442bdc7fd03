// The elevator tracker on synthetic building runs (tools/imu-elevator-run/ride_simulator.h): every
// ride ends on the right floor, nothing is reported while walking, sitting down, on the
// stairs or an escalator, at 10 Hz to 1 kHz, and with broken samples mixed in.

#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <random>

#include <gtest/gtest.h>

#include "tools/imu-elevator-run/offline_run.h"
#include "tools/imu-elevator-run/ride_simulator.h"

namespace evermap::elevator {
namespace {

struct Score {
  int matched = 0;  // true rides with one reported ride over them, on the right floor
  int wrong_floor = 0;
  int missed = 0;
  int spurious = 0;  // reported rides over no true ride
  double worst_error_m = 0;
};

double seconds(int64_t utime) { return 1e-6 * static_cast<double>(utime); }

// Matches reported rides to true ones by overlap; a ride is on the right floor when the
// tracker's floor index maps to the true floor consistently over the whole run.
Score score(const SimulatedRun& truth, const OfflineRun& run, bool print) {
  Score s;
  std::map<int, int> tracker_to_true{{0, 0}};  // both start on floor 0
  std::vector<bool> used(run.rides.size(), false);
  for (const TrueRide& t : truth.rides) {
    int found = -1;
    for (size_t i = 0; i < run.rides.size(); ++i) {
      const Ride& r = run.rides[i];
      if (seconds(r.start_utime) < t.end_s && seconds(r.end_utime) > t.start_s)
        found = static_cast<int>(i);
    }
    if (found < 0) {
      ++s.missed;
      if (print)
        std::printf("  missed: %.1f..%.1f s, floor %d -> %d\n", t.start_s, t.end_s, t.from_floor,
                    t.to_floor);
      continue;
    }
    used[found] = true;
    const Ride& r = run.rides[found];
    s.worst_error_m = std::max(s.worst_error_m, std::abs(r.displacement_m - t.displacement_m));
    auto [it, inserted] = tracker_to_true.emplace(r.to_floor, t.to_floor);
    const bool right = it->second == t.to_floor;
    if (right)
      ++s.matched;
    else
      ++s.wrong_floor;
    if (print) {
      std::printf(
          "  %6.1f..%6.1f s  floor %d -> %d  true %+6.2f m  found %6.1f..%6.1f s %+6.2f m  "
          "table %d%s\n",
          t.start_s, t.end_s, t.from_floor, t.to_floor, t.displacement_m, seconds(r.start_utime),
          seconds(r.end_utime), r.displacement_m, r.to_floor, right ? "" : "  WRONG FLOOR");
    }
  }
  for (size_t i = 0; i < run.rides.size(); ++i) {
    if (!used[i]) {
      ++s.spurious;
      if (print)
        std::printf("  spurious ride at %.1f s: %+.2f m\n", seconds(run.rides[i].start_utime),
                    run.rides[i].displacement_m);
    }
  }
  return s;
}

class ElevatorSynthetic : public ::testing::TestWithParam<double> {};

TEST_P(ElevatorSynthetic, EveryRideEndsOnTheRightFloor) {
  RideSimulatorOptions o;
  o.rate_hz = GetParam();
  o.seed = 11;
  const SimulatedRun truth = simulateRun(o, randomScript(o, 12, 5));
  const OfflineRun run = runImuElevator(truth.samples, {}, {});
  std::printf("%.0f Hz: %zu true rides, %zu found; %s\n", o.rate_hz, truth.rides.size(),
              run.rides.size(), run.counts.summary().c_str());
  const Score s = score(truth, run, true);
  EXPECT_EQ(s.matched, static_cast<int>(truth.rides.size()));
  EXPECT_EQ(s.wrong_floor, 0);
  EXPECT_EQ(s.missed, 0);
  EXPECT_EQ(s.spurious, 0);
  EXPECT_LT(s.worst_error_m, 1.0);
  // No ride starts while walking, sitting down, on stairs or escalators.
  for (const FloorEvent& e : run.events) {
    if (e.kind != FloorEvent::Kind::kRideStart) continue;
    for (const auto& [a, b] : truth.no_ride_intervals) {
      EXPECT_FALSE(seconds(e.utime) > a + 1.0 && seconds(e.utime) < b - 1.0)
          << "ride start at " << seconds(e.utime) << " s inside a no-ride interval " << a << ".."
          << b;
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Rates, ElevatorSynthetic, ::testing::Values(10.0, 50.0, 200.0, 1000.0));

}  // namespace
}  // namespace evermap::elevator
