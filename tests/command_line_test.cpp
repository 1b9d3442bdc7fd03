#include "core/common/command_line.h"

#include <gtest/gtest.h>

#include <vector>

namespace evermap {
namespace {

struct Args {
  std::vector<const char*> argv{"prog"};
  Args(std::initializer_list<const char*> words) { argv.insert(argv.end(), words); }
  int argc() const { return static_cast<int>(argv.size()); }
  const char* const* data() const { return argv.data(); }
};

struct Fixture {
  std::string store;
  double gap = 4.0;
  int count = 3;
  int64_t utime = 0;
  bool quiet = false;
  std::vector<std::string> files;
  CommandLine cli{"prog", "Does things."};
  Fixture() {
    cli.value("--store", &store, "FILE", "the store", /*required=*/true);
    cli.value("--gap", &gap, "M", "gap in metres").any();
    cli.value("--count", &count, "N", "how many").any();
    cli.value("--utime", &utime, "US", "a time").any();
    cli.flag("--quiet", &quiet, "print nothing");
  }
};

TEST(CommandLine, ParsesValuesFlagsAndInlineValues) {
  Fixture f;
  const Args a{"--store", "map.db", "--gap=2.5", "--count", "7", "--utime", "-12", "--quiet"};
  const auto outcome = f.cli.parse(a.argc(), a.data());
  ASSERT_TRUE(outcome.ok()) << outcome.error().message;
  EXPECT_EQ(*outcome, CommandLine::Outcome::kRun);
  EXPECT_EQ(f.store, "map.db");
  EXPECT_DOUBLE_EQ(f.gap, 2.5);
  EXPECT_EQ(f.count, 7);
  EXPECT_EQ(f.utime, -12);
  EXPECT_TRUE(f.quiet);
}

TEST(CommandLine, KeepsDefaultsOfOptionsNotGiven) {
  Fixture f;
  const Args a{"--store", "m"};
  ASSERT_TRUE(f.cli.parse(a.argc(), a.data()).ok());
  EXPECT_DOUBLE_EQ(f.gap, 4.0);
  EXPECT_EQ(f.count, 3);
  EXPECT_FALSE(f.quiet);
}

TEST(CommandLine, ErrorsNameTheOption) {
  struct Case {
    Args args;
    const char* expected;
  };
  const std::vector<Case> cases = {
      {Args{"--gap", "1"}, "--store is required"},
      {Args{"--store", "m", "--bogus", "1"}, "unknown option --bogus"},
      {Args{"--store"}, "--store needs a value"},
      {Args{"--store", "m", "--gap", "nan"}, "bad --gap"},
      {Args{"--store", "m", "--gap", "1x"}, "bad --gap"},
      {Args{"--store", "m", "--count", "2.5"}, "bad --count"},
      {Args{"--store", "m", "--quiet=yes"}, "--quiet takes no value"},
      {Args{"--store", "m", "stray"}, "unexpected argument \"stray\""},
  };
  for (const Case& c : cases) {
    Fixture f;
    const auto outcome = f.cli.parse(c.args.argc(), c.args.data());
    ASSERT_FALSE(outcome.ok()) << c.expected;
    EXPECT_NE(outcome.error().message.find(c.expected), std::string::npos)
        << outcome.error().message;
  }
}

// Issue 17: vo-proc turned --queue -5 into 1. A range is declared with the option and a value
// outside it is refused, naming the option and the bound; the target keeps its default.
TEST(CommandLine, ANumberOutsideItsRangeIsRefusedNamingTheOptionAndTheBound) {
  int queue = 2;
  double rate_hz = 10.0, fraction = 0.5;
  CommandLine cli("prog", "");
  cli.value("--queue", &queue, "N", "queue").min(1).max(1000);
  cli.value("--rate", &rate_hz, "HZ", "rate").positive();
  cli.value("--fraction", &fraction, "F", "fraction").min(0).max(1);
  struct Case {
    Args args;
    const char* expected;  // nullptr: accepted
  };
  const std::vector<Case> cases = {
      {Args{"--queue", "-5"}, "bad --queue: -5 is outside [1, 1000]"},
      {Args{"--queue", "1001"}, "bad --queue: 1001 is outside [1, 1000]"},
      {Args{"--queue", "99999999999999999999"},
       "bad --queue: \"99999999999999999999\" is not an integer in range"},
      {Args{"--rate", "0"}, "bad --rate: 0 is outside > 0"},
      {Args{"--rate", "-1e-300"}, "bad --rate"},
      {Args{"--rate", "inf"}, "bad --rate: \"inf\" is not a finite number"},
      {Args{"--fraction", "1.0000001"}, "bad --fraction: 1.0000001 is outside [0, 1]"},
      {Args{"--queue", "1", "--queue", "1000", "--rate", "1e-9", "--fraction", "0"}, nullptr},
  };
  for (const Case& c : cases) {
    queue = 2;
    const auto outcome = cli.parse(c.args.argc(), c.args.data());
    if (!c.expected) {
      EXPECT_TRUE(outcome.ok()) << outcome.error().message;
      EXPECT_EQ(queue, 1000);
      continue;
    }
    ASSERT_FALSE(outcome.ok()) << c.expected;
    EXPECT_NE(outcome.error().message.find(c.expected), std::string::npos)
        << outcome.error().message;
    EXPECT_EQ(queue, 2) << "a refused value must not be stored";
  }
}

TEST(CommandLine, HelpWinsAndUsageListsEveryOption) {
  Fixture f;
  const Args a{"--help"};
  const auto outcome = f.cli.parse(a.argc(), a.data());
  ASSERT_TRUE(outcome.ok());
  EXPECT_EQ(*outcome, CommandLine::Outcome::kHelp);
  const std::string usage = f.cli.usage();
  EXPECT_NE(usage.find("usage: prog --store FILE [--gap M]"), std::string::npos) << usage;
  for (const char* name : {"--count N", "--utime US", "--quiet", "Does things."}) {
    EXPECT_NE(usage.find(name), std::string::npos) << name;
  }
}

TEST(CommandLine, CollectsPositionalWordsWhenAsked) {
  Fixture f;
  f.cli.positional(&f.files, "FILE...", "inputs");
  const Args a{"a.txt", "--store", "m", "b.txt"};
  ASSERT_TRUE(f.cli.parse(a.argc(), a.data()).ok());
  EXPECT_EQ(f.files, (std::vector<std::string>{"a.txt", "b.txt"}));
}

TEST(CommandLine, RepeatedOptionCollectsEveryValueInOrder) {
  CommandLine cli("t", "test");
  std::vector<std::string> sets;
  cli.repeated("--set", &sets, "KEY=VALUE", "one setting");
  const Args a{"--set", "a=1", "--set=b=2", "--set", "c = 3"};
  ASSERT_TRUE(cli.parse(a.argc(), a.data()).ok());
  EXPECT_EQ(sets, (std::vector<std::string>{"a=1", "b=2", "c = 3"}));
}

TEST(CommandLine, CustomSetterRejectsWithItsMessage) {
  CommandLine cli("prog", "");
  std::string mode = "reduced";
  cli.value(
      "--mode",
      [&](const std::string& v) -> Status {
        if (v != "reduced" && v != "full") return makeError("\"", v, "\" is not reduced or full");
        mode = v;
        return Ok{};
      },
      "M", "graph mode");
  const Args bad{"--mode", "half"};
  const auto outcome = cli.parse(bad.argc(), bad.data());
  ASSERT_FALSE(outcome.ok());
  EXPECT_EQ(outcome.error().message, "bad --mode: \"half\" is not reduced or full");
  const Args good{"--mode", "full"};
  ASSERT_TRUE(cli.parse(good.argc(), good.data()).ok());
  EXPECT_EQ(mode, "full");
}

}  // namespace
}  // namespace evermap
