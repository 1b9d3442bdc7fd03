// core/common/option_fields.h: options print, parse back, and name what is wrong.

#include <cstdio>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "core/common/option_fields.h"
#include "elevator-proc/elevator_tracker.h"
#include "imu-proc/attitude_filter.h"

namespace evermap {
namespace {

TEST(OptionFields, PrintedOptionsLoadBackUnchanged) {
  imu::AttitudeFilterOptions a;
  a.linear_accel_density = 0.123;
  a.gate.max_interval_s = 0.75;
  const auto file = std::filesystem::temp_directory_path() / "evermap_option_fields_test.cfg";
  std::ofstream(file) << "# a comment\n" << describeFields(a) << "\nunknown_key = 3\n";
  imu::AttitudeFilterOptions b;
  ASSERT_TRUE(loadFields(&b, file, false).ok());  // unknown keys belong to other components
  EXPECT_DOUBLE_EQ(b.linear_accel_density, 0.123);
  EXPECT_DOUBLE_EQ(b.gate.max_interval_s, 0.75);
  EXPECT_EQ(describeFields(a), describeFields(b));
  const Status strict = loadFields(&b, file, true);
  ASSERT_FALSE(strict.ok());
  EXPECT_NE(strict.error().message.find("unknown_key"), std::string::npos);
  std::filesystem::remove(file);
}

TEST(OptionFields, BadValuesAndKeysAreNamed) {
  elevator::ElevatorTrackerOptions o;
  ASSERT_TRUE(setFieldFromAssignment(&o, "max_ride_s=120").ok());
  EXPECT_DOUBLE_EQ(o.max_ride_s, 120.0);
  Status st = setFieldFromAssignment(&o, "max_ride_s=fast");
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().message.find("max_ride_s"), std::string::npos);
  st = setFieldFromAssignment(&o, "no_such_option=1");
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().message.find("no_such_option"), std::string::npos);
  EXPECT_FALSE(setFieldFromAssignment(&o, "max_ride_s").ok());
}

}  // namespace
}  // namespace evermap
