// core/common/option_fields.h: an option declared once gives its loading, its check, its help
// line and its printed value.

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "core/common/command_line.h"
#include "core/common/option_fields.h"
#include "mapper-proc/floor_gate.h"

namespace evermap {
namespace {

enum class Shape { kRound, kSquare };

struct InnerOptions {
  int count = 3;
  double weight = 0.25;
  void declareOptions(OptionList& o) {
    o.add("count", &count, "", "how many").min(1);
    o.add("weight", &weight, "", "a fraction").in(0.0, 1.0);
  }
};

struct TestOptions {
  double gap_s = 2.5;
  bool fast = true;
  std::string name = "plain";
  Shape shape = Shape::kSquare;
  uint64_t seed = 7;
  InnerOptions inner;
  void declareOptions(OptionList& o) {
    o.add("gap_s", &gap_s, "s", "longest gap bridged").positive();
    o.add("fast", &fast, "take the short way");
    o.add("name", &name, "", "what it is called");
    o.choice("shape", &shape, {{"round", Shape::kRound}, {"square", Shape::kSquare}},
             "the outline");
    o.add("seed", &seed, "", "random seed").any();
    o.nest("inner.", &inner);
  }
};

std::filesystem::path writeFile(const std::string& name, const std::string& text) {
  const auto path = std::filesystem::temp_directory_path() / name;
  std::ofstream(path) << text;
  return path;
}

struct Args {
  std::vector<const char*> argv;
  Args(std::initializer_list<const char*> args) : argv{"prog"} {
    argv.insert(argv.end(), args.begin(), args.end());
  }
  int argc() const { return static_cast<int>(argv.size()); }
  const char* const* data() const { return argv.data(); }
};

TEST(OptionList, EachDeclaredFieldIsOneHelpLineWithItsDefaultUnitRangeAndDoc) {
  TestOptions o;
  o.gap_s = 9.0;  // the help shows the default, not the value in effect
  const std::string help = OptionList::of(&o, "t.").help();
  // Columns: key, default and unit, allowed values, doc.
  EXPECT_NE(help.find("  t.gap_s         2.5 s   > 0             longest gap bridged\n"),
            std::string::npos)
      << help;
  EXPECT_NE(help.find("  t.shape         square  round | square  the outline\n"), std::string::npos)
      << help;
  EXPECT_NE(help.find("  t.inner.weight  0.25    [0, 1]          a fraction\n"), std::string::npos)
      << help;
  EXPECT_NE(help.find("true | false    take the short way"), std::string::npos) << help;
  EXPECT_EQ(help.find("9"), std::string::npos) << help;
  EXPECT_EQ(std::count(help.begin(), help.end(), '\n'), 7);
}

TEST(OptionList, PrintedValuesReadBackAsAConfigFile) {
  TestOptions a;
  a.gap_s = 0.1;
  a.fast = false;
  a.name = "fancy";
  a.shape = Shape::kRound;
  a.seed = 18446744073709551615u;
  a.inner.count = 12;
  a.inner.weight = 1.0 / 3.0;
  const std::string printed = OptionList::of(&a, "t.").print();
  const auto path = writeFile("evermap_option_list_roundtrip.conf", "# header\n" + printed);
  TestOptions b;
  OptionList list = OptionList::of(&b, "t.");
  ASSERT_TRUE(list.loadFile(path).ok());
  EXPECT_EQ(b.gap_s, 0.1);
  EXPECT_FALSE(b.fast);
  EXPECT_EQ(b.name, "fancy");
  EXPECT_EQ(b.shape, Shape::kRound);
  EXPECT_EQ(b.seed, a.seed);
  EXPECT_EQ(b.inner.count, 12);
  EXPECT_EQ(b.inner.weight, 1.0 / 3.0);  // bit for bit
  EXPECT_EQ(list.print(), printed);
  EXPECT_NE(printed.find("t.gap_s = 0.1  # s\n"), std::string::npos) << printed;
  std::filesystem::remove(path);
}

TEST(OptionList, AValueOutsideItsRangeIsRefusedNamingTheOptionAndTheRange) {
  TestOptions o;
  OptionList list = OptionList::of(&o, "t.");
  const Status zero = list.set("t.gap_s", "0");
  ASSERT_FALSE(zero.ok());
  EXPECT_EQ(zero.error().message, "option t.gap_s: 0 is outside > 0");
  const Status heavy = list.assign("t.inner.weight=1.5");
  ASSERT_FALSE(heavy.ok());
  EXPECT_EQ(heavy.error().message, "option t.inner.weight: 1.5 is outside [0, 1]");
  EXPECT_EQ(list.set("t.inner.count", "2.5").error().message,
            "option t.inner.count: \"2.5\" is not an integer in range");
  EXPECT_EQ(list.set("t.gap_s", "inf").error().message,
            "option t.gap_s: \"inf\" is not a finite number");
  EXPECT_EQ(list.set("t.fast", "maybe").error().message,
            "option t.fast: \"maybe\" is not true or false");
  EXPECT_EQ(o.gap_s, 2.5);  // refused values leave the field as it was
  EXPECT_EQ(o.inner.weight, 0.25);
}

TEST(OptionList, ARangeIsCheckedOnValuesSetInCodeToo) {
  TestOptions o;
  EXPECT_TRUE(checkOptionRanges(o).ok());
  o.inner.count = 0;
  EXPECT_EQ(checkOptionRanges(o, "t.").error().message, "option t.inner.count: 0 is outside >= 1");
}

TEST(OptionList, AnUnknownKeyIsRefusedWithTheFileAndLine) {
  TestOptions o;
  OptionList list = OptionList::of(&o, "t.");
  EXPECT_EQ(list.set("t.gapp_s", "1").error().message, "unknown option \"t.gapp_s\"");
  const auto path = writeFile("evermap_option_list_unknown.conf", "t.gap_s = 1\n\nt.nope = 2\n");
  const Status st = list.loadFile(path);
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().message, path.string() + ":3: unknown option \"t.nope\"");
  const auto bad = writeFile("evermap_option_list_bad.conf", "# c\nt.gap_s = -1  # no\n");
  EXPECT_EQ(list.loadFile(bad).error().message,
            bad.string() + ":2: option t.gap_s: -1 is outside > 0");
  std::filesystem::remove(path);
  std::filesystem::remove(bad);
}

TEST(OptionList, AnEnumTakesOnlyItsNames) {
  TestOptions o;
  OptionList list = OptionList::of(&o);
  ASSERT_TRUE(list.set("shape", "round").ok());
  EXPECT_EQ(o.shape, Shape::kRound);
  EXPECT_EQ(list.set("shape", "oval").error().message,
            "option shape: \"oval\" is not one of round | square");
  EXPECT_EQ(list.find("shape")->get(), "round");
  EXPECT_EQ(list.find("shape")->default_text, "square");
}

TEST(OptionList, NestedStructsTakeTheirPrefix) {
  TestOptions o;
  OptionList list = OptionList::of(&o, "outer.");
  ASSERT_NE(list.find("outer.inner.count"), nullptr);
  EXPECT_EQ(list.find("inner.count"), nullptr);
  ASSERT_TRUE(list.set("outer.inner.count", "5").ok());
  EXPECT_EQ(o.inner.count, 5);
}

TEST(OptionList, MarkdownIsATableRowPerOption) {
  TestOptions o;
  const std::string md = OptionList::of(&o).markdown();
  EXPECT_NE(md.find("| `gap_s` | 2.5 | s | > 0 | longest gap bridged |"), std::string::npos) << md;
  EXPECT_NE(md.find("| `shape` | square |   | round \\| square | the outline |"), std::string::npos)
      << md;
}

TEST(OptionList, ADeclaredStructValidatesItsRanges) {
  mapper::FloorGateOptions gate;
  EXPECT_TRUE(gate.validate().ok());
  gate.max_vertical_speed_m_s = 0.0;
  EXPECT_EQ(gate.validate().error().message,
            "option floor_gate.max_vertical_speed_m_s: 0 is outside > 0");
}

TEST(CommandLineOptions, ConfigThenSetInOrderThenPrintConfig) {
  TestOptions o;
  CommandLine cli("prog", "a test");
  cli.options(&o, "t.");
  const auto path = writeFile("evermap_option_list_cli.conf", "t.gap_s = 4\nt.name = x\n");
  const Args args{"--set", "t.name=y", "--config", path.c_str(), "--set", "t.inner.count=9"};
  const auto outcome = cli.parse(args.argc(), args.data());
  ASSERT_TRUE(outcome.ok()) << outcome.error().message;
  EXPECT_EQ(*outcome, CommandLine::Outcome::kRun);
  EXPECT_EQ(o.gap_s, 4.0);
  EXPECT_EQ(o.name, "y");  // --set after the file, whatever the order on the line
  EXPECT_EQ(o.inner.count, 9);
  std::filesystem::remove(path);
}

TEST(CommandLineOptions, PrintConfigParsesBackAndHelpListsTheOptions) {
  TestOptions o;
  CommandLine cli("prog", "a test");
  cli.options(&o, "t.");
  const Args args{"--set", "t.shape=round", "--print-config"};
  const auto outcome = cli.parse(args.argc(), args.data());
  ASSERT_TRUE(outcome.ok());
  EXPECT_EQ(*outcome, CommandLine::Outcome::kPrintConfig);
  const std::string printed = cli.optionList().print();
  const auto path = writeFile("evermap_option_list_printed.conf", printed);
  TestOptions b;
  ASSERT_TRUE(OptionList::of(&b, "t.").loadFile(path).ok());
  EXPECT_EQ(b.shape, Shape::kRound);
  std::filesystem::remove(path);

  const std::string usage = cli.usage();
  EXPECT_NE(usage.find("--print-config"), std::string::npos) << usage;
  EXPECT_NE(usage.find("--set KEY=VALUE"), std::string::npos) << usage;
  EXPECT_NE(usage.find("t.inner.weight"), std::string::npos) << usage;
  EXPECT_NE(cli.markdown().find("## prog"), std::string::npos);
}

TEST(CommandLineOptions, ABadSetNamesTheOptionAndTheRange) {
  TestOptions o;
  CommandLine cli("prog", "");
  cli.options(&o, "t.");
  const Args args{"--set", "t.inner.weight=2"};
  const auto outcome = cli.parse(args.argc(), args.data());
  ASSERT_FALSE(outcome.ok());
  EXPECT_EQ(outcome.error().message, "bad --set: option t.inner.weight: 2 is outside [0, 1]");
}

TEST(CommandLineOptions, TheOptionsOffTheirDefaultsAreOneLineNamingWhereEachCameFrom) {
  TestOptions o;
  CommandLine cli("prog", "");
  cli.options(&o, "t.");
  cli.alias("--gap", "t.gap_s", "S");
  ASSERT_TRUE(cli.parse(1, Args{}.data()).ok());
  EXPECT_EQ(cli.changedOptionsLine(), "");  // every option at its default: nothing to say

  // A value equal to the default is no change; the file's, --set's and an alias's are, and a
  // key the file and --set both give came from --set (applied after the file).
  const auto path =
      writeFile("evermap_option_list_changed.conf", "t.gap_s = 2.5\nt.name = x\nt.seed = 3\n");
  TestOptions p;
  CommandLine again("prog", "");
  again.options(&p, "t.");
  again.alias("--gap", "t.gap_s", "S");
  const Args args{"--config", path.c_str(), "--set", "t.inner.count=9",
                  "--gap",    "4",          "--set", "t.seed =5"};  // a key read as --set reads it
  ASSERT_TRUE(again.parse(args.argc(), args.data()).ok());
  EXPECT_EQ(again.changedOptionsLine(),
            "prog: options not at their defaults: t.gap_s = 4 (--gap), "
            "t.name = x (" +
                path.string() +
                "), t.seed = 5 (--set), "
                "t.inner.count = 9 (--set)");
  std::filesystem::remove(path);
  const auto changed = again.optionList().changed();
  ASSERT_EQ(changed.size(), 4u);
  EXPECT_EQ(changed[1], (std::pair<std::string, std::string>{"t.name", "x"}));
}

}  // namespace
}  // namespace evermap
