// Mapper options from `mapper.*` settings (mapper-proc/mapper_config.h) and the split of one
// settings file between the simulator and the mapper (KeyValueFile::extract).
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "core/common/key_value_file.h"
#include "core/solver/batch_solver.h"
#include "mapper-proc/mapper_config.h"
#include "tools/sim/sim_options.h"

namespace evermap::mapper {
namespace {

KeyValueFile parse(const std::string& text) {
  auto file = KeyValueFile::parse(text, "x.conf");
  EXPECT_TRUE(file) << file.error().message;
  return *file;
}

TEST(MapperConfig, ReadsEveryKindOfSettingAndKeepsTheDefaultsOfTheRest) {
  const KeyValueFile file = parse(
      "mapper.map_gate = 0\n"
      "mapper.fuse_active_registration = false\n"
      "mapper.heading_bins = 16\n"
      "mapper.overlap_heading_sectors = 0.5\n"
      "mapper.closure_partners = 5\n"
      "mapper.saturated_closure_information = 1.5\n"
      "mapper.loop_kernel = cauchy:2\n"
      "mapper.vetted_loop_kernel = dcs\n"
      "mapper.solver.batch_every = 50\n"
      "mapper.solver.method = dogleg\n"
      "mapper.solver.background_batch_lag = 0\n"
      "mapper.tracker.history_s = 60\n"
      "mapper.tracker.vo_gyro_gate = 9\n"
      "mapper.tracker.heading_wait_s = 0.05\n");
  MapperOptions o;
  const Status read = readMapperOptions(file, &o);
  ASSERT_TRUE(read) << read.error().message;
  EXPECT_EQ(o.map_gate, 0.0);
  EXPECT_FALSE(o.fuse_active_registration);
  EXPECT_EQ(o.heading_bins, 16);
  EXPECT_EQ(o.overlap_heading_sectors, 0.5);
  EXPECT_EQ(o.closure_partners, 5);
  EXPECT_EQ(o.saturated_closure_information, 1.5);
  EXPECT_EQ(o.loop_kernel.type, solver::KernelType::kCauchy);
  EXPECT_EQ(o.loop_kernel.parameter, 2.0);
  EXPECT_EQ(o.vetted_loop_kernel.type, solver::KernelType::kDcs);
  EXPECT_EQ(o.solver.batch_every, 50);
  EXPECT_EQ(o.solver.method, solver::Method::kDogLeg);
  EXPECT_EQ(o.solver.background_batch_lag, 0);
  EXPECT_EQ(o.tracker.history_s, 60.0);
  EXPECT_EQ(o.tracker.vo_gyro_gate, 9.0);
  EXPECT_EQ(o.tracker.heading_wait_s, 0.05);
  const MapperOptions defaults;
  EXPECT_EQ(o.cell_size_m, defaults.cell_size_m);
  EXPECT_EQ(o.consistency_gate, defaults.consistency_gate);
  EXPECT_EQ(o.solver.wildfire_threshold, defaults.solver.wildfire_threshold);
}

TEST(MapperConfig, ErrorsNameTheKeyAndWhereItWasSet) {
  struct Case {
    std::string text;
    std::string expected;
  };
  for (const Case& c :
       {Case{"mapper.map_gat = 3\n", "x.conf:1: unknown option \"mapper.map_gat\""},
        Case{"\nmapper.heading_bins = many\n", "x.conf:2"},
        Case{"mapper.loop_kernel = tukey\n", "mapper.loop_kernel"},
        Case{"mapper.solver.method = lm\n", "mapper.solver.method"},
        Case{"mapper.map_gate = -1\n", "mapper.map_gate"},
        Case{"mapper.closure_partners = 1\n", "mapper.closure_partners"},
        Case{"mapper.saturated_closure_information = -2\n", "mapper.saturated_closure_information"},
        Case{"mapper.saturated_closure_information = inf\n",
             "mapper.saturated_closure_information"}}) {
    MapperOptions o;
    const Status s = readMapperOptions(parse(c.text), &o);
    ASSERT_FALSE(s) << c.text;
    EXPECT_NE(s.error().message.find(c.expected), std::string::npos) << s.error().message;
  }
}

TEST(MapperConfig, OneFileHoldsTheSimulatorsAndTheMappersSettings) {
  KeyValueFile file =
      parse("seed = 7\nmapper.map_gate = 10\noracle.false_match_rate_node = 0.05\n");
  ASSERT_TRUE(file.set("mapper.cell_size_m=2", "--set mapper.cell_size_m=2"));
  const KeyValueFile mapper_keys = file.extract("mapper.");
  EXPECT_EQ(mapper_keys.entries().size(), 2u);
  EXPECT_EQ(file.entries().size(), 2u);
  EXPECT_EQ(file.find("mapper.map_gate"), nullptr);
  auto sim = sim::loadSimOptions(file);  // no unknown mapper.* keys left for the simulator
  ASSERT_TRUE(sim) << sim.error().message;
  EXPECT_EQ(sim->seed, 7u);
  MapperOptions o;
  ASSERT_TRUE(readMapperOptions(mapper_keys, &o));
  EXPECT_EQ(o.map_gate, 10.0);
  EXPECT_EQ(o.cell_size_m, 2.0);
  // An override keeps its origin for messages.
  EXPECT_EQ(mapper_keys.find("mapper.cell_size_m")->origin, "--set mapper.cell_size_m=2");
}

TEST(MapperConfig, PrintedOptionsReadBackToTheSameOptions) {
  MapperOptions a;
  a.map_gate = 10.5;
  a.loop_kernel = *solver::parseRobustKernel("cauchy:2.5");
  a.vetted_loop_kernel = *solver::parseRobustKernel("gnc");
  a.solver.method = solver::Method::kDogLeg;
  a.solver.background_batch_lag = 0;
  a.tracker.gyro_heading = false;
  a.floor_gate.max_height_m = 300.0;
  const std::string printed = printMapperOptions(a);
  MapperOptions b;
  const Status read = readMapperOptions(parse(printed), &b);
  ASSERT_TRUE(read) << read.error().message << "\n" << printed;
  EXPECT_EQ(OptionList::of(&b, "mapper.").print(), printed);
  EXPECT_EQ(b.loop_kernel.type, solver::KernelType::kCauchy);
  EXPECT_EQ(b.loop_kernel.parameter, 2.5);
  EXPECT_EQ(b.vetted_loop_kernel.type, solver::KernelType::kGncTls);
  EXPECT_EQ(b.solver.method, solver::Method::kDogLeg);
  EXPECT_FALSE(b.tracker.gyro_heading);
  EXPECT_EQ(b.floor_gate.max_height_m, 300.0);
  EXPECT_NE(printed.find("mapper.loop_kernel = cauchy:2.5\n"), std::string::npos) << printed;
  EXPECT_NE(printed.find("mapper.solver.method = dogleg\n"), std::string::npos) << printed;
}

TEST(MapperConfig, EveryKeyIsDeclaredOnceWithItsDefaultUnitRangeAndDoc) {
  MapperOptions o;
  const OptionList list = OptionList::of(&o, "mapper.");
  EXPECT_GE(list.fields().size(), 59u);  // the 65 keys of before, less the six experiments removed
  for (const OptionField& f : list.fields()) {
    EXPECT_FALSE(f.doc.empty()) << f.key;
    EXPECT_FALSE(f.allowedText().empty()) << f.key;
    EXPECT_FALSE(f.default_text.empty()) << f.key;
  }
  EXPECT_EQ(list.find("mapper.map_gate")->default_text, "22.46");
  EXPECT_EQ(list.find("mapper.loop_kernel")->default_text, "dcs:20");
  EXPECT_EQ(list.find("mapper.vetted_loop_kernel")->default_text, "none");
  EXPECT_EQ(list.find("mapper.solver.wildfire_threshold")->default_text, "0.001");
  EXPECT_EQ(list.find("mapper.solver.method")->default_text, "gn");
  EXPECT_EQ(list.find("mapper.overlap_radius_cells")->allowedText(), "[0, 3]");
  EXPECT_EQ(list.find("mapper.floor_gate.max_height_m")->unit, "m");
}

TEST(MapperConfig, ARangeErrorNamesTheFileLineOptionAndRange) {
  MapperOptions o;
  const Status s = readMapperOptions(parse("\nmapper.overlap_radius_cells = 4\n"), &o);
  ASSERT_FALSE(s);
  EXPECT_EQ(s.error().message, "x.conf:2: option mapper.overlap_radius_cells: 4 is outside [0, 3]");
}

// The shipped configs (their mapper.* keys) load, with every value inside its range.
TEST(MapperConfig, TheShippedConfigsLoad) {
  for (const auto& entry :
       std::filesystem::directory_iterator(std::filesystem::path(EVERMAP_SOURCE_DIR) / "config")) {
    if (entry.path().extension() != ".conf") continue;
    auto file = KeyValueFile::load(entry.path());
    ASSERT_TRUE(file) << file.error().message;
    MapperOptions o;
    const Status s = readMapperOptions(file->extract("mapper."), &o);
    EXPECT_TRUE(s) << s.error().message;
  }
}

}  // namespace
}  // namespace evermap::mapper
