// Configuration files of the simulator: the shipped ones load, every kind of mistake is an
// error naming the file and line, and a printed configuration reads back identically.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "core/common/key_value_file.h"
#include "test_data.h"
#include "tools/sim/run.h"

namespace evermap::sim {
namespace {

Expected<SimOptions> parse(const std::string& text) {
  auto file = KeyValueFile::parse(text, "x.conf");
  if (!file) return file.error();
  return loadSimOptions(*file);
}

std::string errorOf(const std::string& text) {
  auto o = parse(text);
  return o ? std::string("(no error)") : o.error().message;
}

TEST(SimConfig, ShippedConfigurationsLoad) {
  for (const char* name : {"sim-paper-scale.conf", "sim-kitti00.conf", "sim-small.conf"}) {
    const auto path = std::filesystem::path(EVERMAP_SOURCE_DIR) / "config" / name;
    auto file = KeyValueFile::load(path);
    ASSERT_TRUE(file.ok()) << file.error().message;
    auto o = loadSimOptions(*file);
    EXPECT_TRUE(o.ok()) << name << ": " << (o.ok() ? "" : o.error().message);
  }
  auto paper = loadSimOptions(*KeyValueFile::load(std::filesystem::path(EVERMAP_SOURCE_DIR) /
                                                  "config/sim-paper-scale.conf"));
  ASSERT_TRUE(paper.ok());
  EXPECT_EQ(paper->building.floors, 10);
  EXPECT_EQ(paper->patrol.sessions, 14);
}

TEST(SimConfig, KittiConfigurationFindsItsTrajectory) {
  EVERMAP_REQUIRE_DATA(dir, "kitti-gt-poses");
  auto file =
      KeyValueFile::load(std::filesystem::path(EVERMAP_SOURCE_DIR) / "config/sim-kitti00.conf");
  ASSERT_TRUE(file.ok());
  ASSERT_TRUE(file->set("trajectory.file = " + (dir / "00.txt").string(), "test").ok());
  auto o = loadSimOptions(*file);
  ASSERT_TRUE(o.ok()) << o.error().message;
  auto plan = RunPlan::create(*o);
  ASSERT_TRUE(plan.ok()) << plan.error().message;
  EXPECT_EQ(plan->sessions(), 1);
  EXPECT_NEAR(plan->session(0).distance_m, 3724.0, 5.0);  // the length SOURCE.txt gives
}

TEST(SimConfig, ErrorsNameTheFileAndLine) {
  EXPECT_EQ(errorOf("seed = 1\nvo.rate_hx = 20\n"), "x.conf:2: unknown option \"vo.rate_hx\"");
  EXPECT_EQ(errorOf("# comment\n\nvo.rate_hz = fast\n"),
            "x.conf:3: option vo.rate_hz: \"fast\" is not a number");
  EXPECT_EQ(errorOf("patrol.sessions = 2.5\n"),
            "x.conf:1: option patrol.sessions: \"2.5\" is not an integer in range");
  EXPECT_EQ(errorOf("imu.enabled = maybe\n"),
            "x.conf:1: option imu.enabled: \"maybe\" is not true or false");
  EXPECT_EQ(errorOf("seed = 1\nseed = 2\n"), "x.conf:2: key 'seed' already set at x.conf:1");
  EXPECT_EQ(errorOf("seed 1\n"), "x.conf:1: expected 'key = value', got 'seed 1'");
  EXPECT_EQ(errorOf("seed =\n"), "x.conf:1: key 'seed' has no value");
  EXPECT_EQ(errorOf("vo.rate_hz = nan\n"),
            "x.conf:1: option vo.rate_hz: \"nan\" is not a finite number");
  EXPECT_EQ(errorOf("mode = sky\n"),
            "x.conf:1: option mode: \"sky\" is not one of building | trajectory");
}

TEST(SimConfig, InvalidSettingsNameTheKeyAndLine) {
  EXPECT_EQ(errorOf("seed = 3\nvo.rate_hz = -1\n"),
            "x.conf:2: option vo.rate_hz: -1 is outside > 0");
  EXPECT_EQ(errorOf("building.main_floor = 12\n"),
            "x.conf:1: building.main_floor: must be in [0, floors), got 12");
  EXPECT_EQ(errorOf("oracle.false_match_rate_node = 1.5\n").substr(0, 9), "x.conf:1:");
  EXPECT_EQ(errorOf("mode = trajectory\n"),
            "x.conf (default value): trajectory.file: needed with mode = trajectory");
  auto missing = KeyValueFile::load("/nonexistent/sim.conf");
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.error().message, "/nonexistent/sim.conf: cannot open configuration file");
}

TEST(SimConfig, MetaKeysAreIgnoredAndOverridesReplaceValues) {
  auto file = KeyValueFile::parse("seed = 4\nmeta.floor.0.height_m = 0.0\n", "x.conf");
  ASSERT_TRUE(file.ok());
  ASSERT_TRUE(file->set("seed=5", "--set seed=5").ok());
  ASSERT_TRUE(file->set("vo.rate_hz = 15", "--set").ok());
  EXPECT_FALSE(file->set("novalue", "--set novalue").ok());
  auto o = loadSimOptions(*file);
  ASSERT_TRUE(o.ok()) << o.error().message;
  EXPECT_EQ(o->seed, 5u);
  EXPECT_EQ(o->sensors.vo.rate_hz, 15.0);
}

TEST(SimConfig, SetAllAppliesEveryOverrideAndNamesTheBadOne) {
  auto file = KeyValueFile::parse("seed = 4\n", "x.conf");
  ASSERT_TRUE(file.ok());
  ASSERT_TRUE(file->setAll({"seed=6", "vo.rate_hz = 12"}, "--set").ok());
  auto o = loadSimOptions(*file);
  ASSERT_TRUE(o.ok()) << o.error().message;
  EXPECT_EQ(o->seed, 6u);
  EXPECT_EQ(o->sensors.vo.rate_hz, 12.0);
  const Status bad = file->setAll({"seed=7", "novalue"}, "--sim-set");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("--sim-set novalue"), std::string::npos)
      << bad.error().message;
}

TEST(SimConfig, PrintedConfigurationReadsBackIdentically) {
  SimOptions o;
  o.seed = 123456789012345ull;
  o.sensors.vo.translation_sigma_per_m = 0.1 + 0.2;  // not exactly representable in short decimal
  o.patrol.total_hours = 1.0 / 3.0;
  o.output.split_sessions = false;
  const std::string text = o.toConfigText();
  auto back = parse(text);
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(back->toConfigText(), text);
  EXPECT_EQ(back->sensors.vo.translation_sigma_per_m, 0.1 + 0.2);
  EXPECT_EQ(back->patrol.total_hours, 1.0 / 3.0);
}

}  // namespace
}  // namespace evermap::sim
