#include "core/common/progress.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace evermap {
namespace {

// A reporter on a clock the test moves by hand.
struct Fixture {
  double now_s = 100.0;
  std::vector<std::string> lines;
  ProgressReporter reporter{"prog", "frames", [this](const std::string& l) { lines.push_back(l); },
                            10.0, [this] { return now_s; }};
};

TEST(ProgressReporter, StaysQuietUntilThePeriodHasPassed) {
  Fixture f;
  f.now_s += 9.9;
  EXPECT_FALSE(f.reporter.update({1.0, 10.0, -1.0, 5, 1}));
  EXPECT_TRUE(f.lines.empty());
  f.now_s += 0.1;
  EXPECT_TRUE(f.reporter.update({2.0, 10.0, -1.0, 6, 1}));
  ASSERT_EQ(f.lines.size(), 1u);
}

TEST(ProgressReporter, CountsThePeriodFromTheLastLine) {
  Fixture f;
  f.now_s += 15.0;
  EXPECT_TRUE(f.reporter.update({}));
  f.now_s += 5.0;
  EXPECT_FALSE(f.reporter.update({}));
  f.now_s += 5.0;
  EXPECT_TRUE(f.reporter.update({}));
  f.reporter.report({});
  EXPECT_EQ(f.lines.size(), 3u);
  EXPECT_FALSE(f.reporter.update({}));
}

TEST(ProgressReporter, TextLinesShareThePeriod) {
  Fixture f;
  f.reporter.reportText("making 58 textures");
  f.now_s += 5.0;
  EXPECT_FALSE(f.reporter.updateText("20 of 58 textures made"));
  f.now_s += 5.0;
  EXPECT_TRUE(f.reporter.updateText("40 of 58 textures made"));
  EXPECT_EQ(f.lines,
            (std::vector<std::string>{"prog: making 58 textures", "prog: 40 of 58 textures made"}));
}

TEST(ProgressReporter, LineSaysDataTimeStepsNodesRateAndTimeLeft) {
  Fixture f;
  EXPECT_EQ(f.reporter.line({12.0, 60.0, -1.0, 240, 3}, 8.0),
            "prog: data 12.0 / 60.0 s (20%), 240 frames, 3 nodes, 1.50x real time, 32 s left");
  EXPECT_EQ(f.reporter.line({60.0, 7260.0, -1.0, 10, -1}, 60.0),
            "prog: data 60.0 / 7260.0 s (0%), 10 frames, 1.00x real time, 2 h 00 min left");
  EXPECT_EQ(f.reporter.line({30.0, 230.0, -1.0, 10, -1}, 30.0),
            "prog: data 30.0 / 230.0 s (13%), 10 frames, 1.00x real time, 3 min 20 s left");
}

TEST(ProgressReporter, LineTakesTheFractionDoneWhenTheTotalIsNotKnown) {
  Fixture f;
  Progress p{20.0, 0.0, 0.25, 400, 5};
  EXPECT_EQ(f.reporter.line(p, 10.0),
            "prog: data 20.0 s (25%), 400 frames, 5 nodes, 2.00x real time, 30 s left");
}

TEST(ProgressReporter, LineWithoutATotalHasNoTimeLeft) {
  Fixture f;
  EXPECT_EQ(f.reporter.line({5.0, 0.0, -1.0, 7, 2}, 10.0),
            "prog: data 5.0 s, 7 frames, 2 nodes, 0.50x real time");
  EXPECT_EQ(f.reporter.line({0.0, 0.0, -1.0, 0, -1}, 0.0), "prog: data 0.0 s, 0 frames");
}

}  // namespace
}  // namespace evermap
