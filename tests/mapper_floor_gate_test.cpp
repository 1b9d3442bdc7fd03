// mapper-proc/floor_gate: FLOOR messages whose height no building has, or whose height
// changed faster than an elevator moves, are refused naming the bound; in the mapper they are
// counted and leave the estimate as it was (issue 17, deliverable 3).

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include "mapper-proc/floor_gate.h"
#include "mapper-proc/mapper.h"
#include "tests/mapper_messages.h"
#include "tests/scripted_drive.h"

namespace evermap::mapper {
namespace {

using namespace testing;  // tests/mapper_messages.h, tests/scripted_drive.h

bool names(const std::string& why, const char* bound) {
  return why.find(bound) != std::string::npos;
}

TEST(FloorGate, RefusesHeightsNoBuildingHasAndRidesFasterThanAnElevator) {
  FloorGateOptions o;
  o.max_height_m = 500.0;
  o.max_vertical_speed_m_s = 10.0;
  FloorGate gate(o);
  // The first message is checked against the height bound only.
  EXPECT_TRUE(names(gate.check(floorMsg(0, floor_t::EVENT_RIDE_START, 501.0, -1)),
                    "floor_gate.max_height_m 500"));
  EXPECT_TRUE(names(gate.check(floorMsg(0, floor_t::EVENT_RIDE_START, -501.0, -1)),
                    "floor_gate.max_height_m"));
  const floor_t start = floorMsg(1'000'000, floor_t::EVENT_RIDE_START, 0.0, -1);
  ASSERT_EQ(gate.check(start), "");
  gate.accept(start);
  // 40 m in 2 s is 20 m/s; 40 m in 5 s is 8 m/s.
  const std::string fast = gate.check(floorMsg(3'000'000, floor_t::EVENT_RIDE_END, 40.0, 1));
  EXPECT_TRUE(names(fast, "floor_gate.max_vertical_speed_m_s 10")) << fast;
  const floor_t end = floorMsg(6'000'000, floor_t::EVENT_RIDE_END, 40.0, 1);
  ASSERT_EQ(gate.check(end), "");
  gate.accept(end);
  // A height jump without a ride, at once: a start 4.5 m from the end in the same
  // microsecond (spans under 1 ms count as 1 ms).
  EXPECT_TRUE(names(gate.check(floorMsg(6'000'000, floor_t::EVENT_RIDE_START, 44.5, -1)),
                    "floor_gate.max_vertical_speed_m_s"));
  EXPECT_EQ(gate.check(floorMsg(6'000'000, floor_t::EVENT_RIDE_START, 40.0, -1)), "");
  // A new session starts wherever the operator says (within the height bound).
  EXPECT_EQ(gate.check(floorMsg(6'000'001, floor_t::EVENT_NONE, -100.0, 0)), "");
  EXPECT_FALSE(gate.check(floorMsg(6'000'001, floor_t::EVENT_NONE, 1e6, 0)).empty());
}

TEST(FloorGateOptions, RefusesNonPositiveOrNonFiniteBounds) {
  FloorGateOptions o;
  EXPECT_TRUE(o.validate());
  o.max_height_m = 0.0;
  EXPECT_FALSE(o.validate());
  o = FloorGateOptions{};
  o.max_vertical_speed_m_s = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(o.validate());
  o.max_vertical_speed_m_s = std::nan("");
  EXPECT_FALSE(o.validate());
  MapperOptions m = scriptedOptions();
  m.floor_gate.max_vertical_speed_m_s = -1.0;
  EXPECT_FALSE(m.validate());
}

TEST(FloorGate, TheMapperRefusesAnImplausibleFloorCountsItAndKeepsItsEstimate) {
  Mapper m(scriptedOptions());
  ASSERT_TRUE(m.onVo(voRestart(0)));
  ASSERT_EQ(m.nodes().size(), 1u);
  ASSERT_TRUE(m.onFloor(floorMsg(1'000'000, floor_t::EVENT_RIDE_START, 0.0, -1)));
  ASSERT_TRUE(m.onFloor(floorMsg(5'000'000, floor_t::EVENT_RIDE_END, 4.5, 1)));
  ASSERT_EQ(m.floor(), 1);
  const SE3d pose = m.pose().mean;
  const auto floors = m.floors();
  const int64_t dropped = m.stats().dropped;
  // A ride of 300 m in 2 s (150 m/s), then one to 5 km: neither is taken.
  ASSERT_TRUE(m.onFloor(floorMsg(6'000'000, floor_t::EVENT_RIDE_START, 4.5, -1)));
  const Status fast = m.onFloor(floorMsg(8'000'000, floor_t::EVENT_RIDE_END, 304.5, 2));
  ASSERT_FALSE(fast);
  EXPECT_NE(fast.error().message.find("floor_gate.max_vertical_speed_m_s 25"), std::string::npos)
      << fast.error().message;
  const Status high = m.onFloor(floorMsg(9'000'000, floor_t::EVENT_RIDE_END, 5000.0, 2));
  ASSERT_FALSE(high);
  EXPECT_NE(high.error().message.find("floor_gate.max_height_m 1000"), std::string::npos)
      << high.error().message;
  EXPECT_EQ(m.stats().implausible_floors, 2);
  EXPECT_EQ(m.stats().dropped, dropped + 2);
  EXPECT_EQ(m.floor(), 1);
  EXPECT_EQ(m.floors(), floors);
  EXPECT_LT((m.pose().mean.inverse() * pose).log().norm(), 1e-12);
  // The ride's true end, after them: taken (checked against the start, not the refused ones).
  ASSERT_TRUE(m.onFloor(floorMsg(20'000'000, floor_t::EVENT_RIDE_END, 9.0, 2)));
  EXPECT_EQ(m.floor(), 2);
  EXPECT_NEAR(m.pose().mean.translation().z(), 9.0, 1e-6);
}

}  // namespace
}  // namespace evermap::mapper
