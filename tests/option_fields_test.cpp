// core/common/option_fields.h: options print, parse back, and name what is wrong.

#include <algorithm>
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
  std::ofstream(file) << "# a comment\n" << describeFields(a);
  imu::AttitudeFilterOptions b;
  ASSERT_TRUE(loadFields(file, &b).ok());
  EXPECT_DOUBLE_EQ(b.linear_accel_density, 0.123);
  EXPECT_DOUBLE_EQ(b.gate.max_interval_s, 0.75);
  EXPECT_EQ(describeFields(a), describeFields(b));
  std::filesystem::remove(file);
}

// Issue 17: imu-proc's --config ignored unknown keys (its --set refused them) and took
// publish_rate_hz=inf. A config file now follows the rules of --set.
TEST(OptionFields, AConfigFileRefusesUnknownKeysAndNonFiniteValuesAsSetDoes) {
  const auto file = std::filesystem::temp_directory_path() / "evermap_option_fields_strict.cfg";
  imu::AttitudeFilterOptions a;
  elevator::ElevatorTrackerOptions e;
  for (const std::string bad : {"unknown_key = 3", "max_ride_s = inf", "max_ride_s = nan",
                                "max_ride_s = -inf", "max_ride_s = 1e999"}) {
    std::ofstream(file) << "# line 1\n" << bad << "\n";
    const Status from_file = loadFields(file, &a, &e);
    ASSERT_FALSE(from_file.ok()) << bad;
    EXPECT_NE(from_file.error().message.find(file.string() + ":2: "), std::string::npos)
        << from_file.error().message;
    std::string assignment = bad;
    assignment.erase(std::remove(assignment.begin(), assignment.end(), ' '), assignment.end());
    EXPECT_FALSE(setFieldFromAssignment(assignment, &a, &e).ok()) << bad;
  }
  std::filesystem::remove(file);
}

TEST(OptionFields, AKeyGoesToTheStructThatHasItAndABadValueIsNotMaskedByTheOthers) {
  imu::AttitudeFilterOptions a;
  elevator::ElevatorTrackerOptions e;
  ASSERT_TRUE(setFieldFromAssignment("max_ride_s=90", &a, &e).ok());
  EXPECT_DOUBLE_EQ(e.max_ride_s, 90.0);
  const Status st = setFieldFromAssignment("max_ride_s=fast", &a, &e);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().message.find("option max_ride_s: \"fast\" is not a number"),
            std::string::npos)
      << st.error().message;
  const Status unknown = setFieldFromAssignment("nope=1", &a, &e);
  ASSERT_FALSE(unknown.ok());
  EXPECT_NE(unknown.error().message.find("unknown option \"nope\""), std::string::npos);
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
