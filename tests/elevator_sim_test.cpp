// imu-proc and elevator-proc on the measurement-level simulator's raw IMU (tools/sim): the
// robot patrols a 10-floor building and rides the elevator to every floor; every ride must
// end on the right floor (issue 8), with the floor table built up as the rides happen.
//
// A shortened run of config/sim-paper-scale.conf's building: 2 sessions, the second visiting
// all nine other floors (each visit a ride there and one back, sometimes with intermediate
// stops), IMU at 200 Hz. The full run: `evermap-imu-elevator-run --sim-config
// config/sim-paper-scale.conf --sim-set imu.rate_hz=200` (docs/imu-elevator.md).

#include <cstdio>

#include <gtest/gtest.h>

#include "tools/imu-elevator-run/sim_floor_check.h"

namespace evermap::elevator {
namespace {

sim::SimOptions shortTenFloorRun(double imu_rate_hz, double margin_s) {
  sim::SimOptions o;
  o.seed = 1;
  o.building.floors = 10;
  o.building.main_floor = 2;
  o.patrol.sessions = 2;
  o.patrol.total_hours = 0.1;  // the visits of every floor make the second session longer
  o.patrol.span_days = 1;
  o.elevator.intermediate_stop_probability = 0.25;
  o.sensors.imu.rate_hz = imu_rate_hz;
  o.sensors.imu.margin_s = margin_s;
  return o;
}

void expectEveryRideOnTheRightFloor(const SimFloorCheck& c) {
  std::printf("%s%s\n", c.table().c_str(), c.summary().c_str());
  EXPECT_EQ(c.floors_visited.size(), 10u) << "the run must reach all 10 floors";
  EXPECT_GE(c.rides.size(), 18u);
  for (const SimRideCheck& r : c.rides) {
    EXPECT_TRUE(r.found) << "ride " << r.floor_from << " -> " << r.floor_to << " missed";
    EXPECT_TRUE(r.right_floor) << "ride " << r.floor_from << " -> " << r.floor_to << " ended on "
                               << r.mapped_floor;
    // The vertical watch announces the cab's motion within about a second (median 1.1 s).
    EXPECT_GE(r.alarm_latency_s, 0.0) << "ride " << r.floor_from << " -> " << r.floor_to;
    EXPECT_LT(r.alarm_latency_s, 2.5) << "ride " << r.floor_from << " -> " << r.floor_to;
  }
  EXPECT_EQ(c.correct(), static_cast<int>(c.rides.size()));
  EXPECT_EQ(c.spurious, 0);
  EXPECT_EQ(c.false_alarms, 0);
  EXPECT_EQ(c.table_heights.size(), 10u) << "one table floor per building floor";
  EXPECT_LT(c.worstErrorM(), 1.5);  // the floor table's match threshold; storeys are 4.1-4.9 m
}

TEST(ElevatorSimulator, EveryRideOfATenFloorRunEndsOnTheRightFloorAt200Hz) {
  const auto c = checkSimulatedFloors(shortTenFloorRun(200.0, 10.0), {}, {});
  ASSERT_TRUE(c.ok()) << c.error().message;
  expectEveryRideOnTheRightFloor(*c);
}

// The paper-scale configuration's IMU: 50 Hz.
TEST(ElevatorSimulator, EveryRideOfATenFloorRunEndsOnTheRightFloorAt50Hz) {
  const auto c = checkSimulatedFloors(shortTenFloorRun(50.0, 10.0), {}, {});
  ASSERT_TRUE(c.ok()) << c.error().message;
  expectEveryRideOnTheRightFloor(*c);
}

TEST(ElevatorSimulator, ATrajectoryRunIsRefusedWithAMessage) {
  sim::SimOptions o = shortTenFloorRun(200.0, 10.0);
  o.mode = sim::SimOptions::Mode::kTrajectory;
  const auto c = checkSimulatedFloors(o, {}, {});
  ASSERT_FALSE(c.ok());
  EXPECT_NE(c.error().message.find("mode"), std::string::npos);
}

}  // namespace
}  // namespace evermap::elevator
