// The deputy's pure parts: respawn back-off, output batching and rate limit, how an exec
// string is launched, and /proc parsing.
#include <gtest/gtest.h>

#include <unistd.h>

#include <fstream>

#include "tools/deputy/backoff.h"
#include "tools/deputy/child_process.h"
#include "tools/deputy/output_throttle.h"
#include "tools/deputy/proc_stats.h"

namespace evermap::deputy {
namespace {

using Clock = OutputThrottle::Clock;
using std::chrono::milliseconds;

TEST(RespawnBackoff, GrowsGeometricallyUpToTheMaximum) {
  BackoffOptions o;
  o.initial_delay_ms = 100;
  o.factor = 2;
  o.max_delay_ms = 1000;
  o.stable_after_s = 10;
  ASSERT_TRUE(o.validate().ok());
  RespawnBackoff b(o);
  const std::vector<double> expected = {100, 200, 400, 800, 1000, 1000};
  for (double e : expected) EXPECT_DOUBLE_EQ(b.onExit(0.5), e);
  EXPECT_EQ(b.consecutiveShortRuns(), 6);
}

TEST(RespawnBackoff, StableRunResetsTheWait) {
  BackoffOptions o;
  o.initial_delay_ms = 100;
  o.stable_after_s = 10;
  RespawnBackoff b(o);
  b.onExit(1);
  b.onExit(1);
  EXPECT_DOUBLE_EQ(b.onExit(1), 400);
  EXPECT_DOUBLE_EQ(b.onExit(10.0), 100);  // ran long enough: start over
  EXPECT_DOUBLE_EQ(b.onExit(9.9), 200);
  b.reset();
  EXPECT_DOUBLE_EQ(b.onExit(0), 100);
}

TEST(RespawnBackoff, LongCrashLoopsStayAtTheMaximum) {
  RespawnBackoff b;
  double last = 0;
  for (int i = 0; i < 5000; ++i) last = b.onExit(0);
  EXPECT_DOUBLE_EQ(last, BackoffOptions{}.max_delay_ms);
}

TEST(RespawnBackoff, OptionsRefuseNonsense) {
  BackoffOptions o;
  o.factor = 0.5;
  EXPECT_FALSE(o.validate().ok());
  o = {};
  o.max_delay_ms = 1;
  EXPECT_FALSE(o.validate().ok());
  o = {};
  o.stable_after_s = 0;
  EXPECT_FALSE(o.validate().ok());
}

TEST(OutputThrottle, BatchesLinesUntilTheFlushInterval) {
  OutputThrottleOptions o;
  o.flush_interval_ms = 100;
  OutputThrottle t(o);
  const auto t0 = Clock::now();
  t.addLine("a", "one", t0);
  t.addLine("a", "two", t0 + milliseconds(10));
  t.addLine("b", "other", t0 + milliseconds(20));
  EXPECT_TRUE(t.takeDue(t0 + milliseconds(50)).empty());
  EXPECT_EQ(t.nextDue(), t0 + milliseconds(100));
  auto due = t.takeDue(t0 + milliseconds(100));
  ASSERT_EQ(due.size(), 1u);
  EXPECT_EQ(due[0].name, "a");
  EXPECT_EQ(due[0].text, "one\ntwo\n");
  due = t.takeDue(t0 + milliseconds(120));
  ASSERT_EQ(due.size(), 1u);
  EXPECT_EQ(due[0].text, "other\n");
  EXPECT_EQ(t.nextDue(), Clock::time_point::max());
}

TEST(OutputThrottle, SplitsBigBatchesAtLineEnds) {
  OutputThrottleOptions o;
  o.max_message_bytes = 100;
  o.burst_bytes = 1e6;
  OutputThrottle t(o);
  const auto t0 = Clock::now();
  const std::string line(29, 'x');  // 30 bytes with '\n'
  for (int i = 0; i < 10; ++i) t.addLine("a", line, t0);
  const auto due = t.takeDue(t0);  // big enough to be due at once
  ASSERT_EQ(due.size(), 4u);
  std::string all;
  for (const auto& b : due) {
    EXPECT_LE(b.text.size(), 100u);
    EXPECT_EQ(b.text.back(), '\n');
    all += b.text;
  }
  EXPECT_EQ(all.size(), 300u);
}

TEST(OutputThrottle, DropsLinesOverTheRateAndSaysHowMany) {
  OutputThrottleOptions o;
  o.max_bytes_per_s = 1000;
  o.burst_bytes = 8192;
  o.max_message_bytes = 8192;
  OutputThrottle t(o);
  const auto t0 = Clock::now();
  const std::string line(99, 'x');                         // 100 bytes with '\n'
  for (int i = 0; i < 100; ++i) t.addLine("a", line, t0);  // 10000 bytes at once
  EXPECT_EQ(t.droppedLines(), 100 - 81);                   // 8192 / 100 = 81 fit the burst
  auto due = t.takeDue(t0, true);
  size_t sent = 0;
  for (const auto& b : due) sent += b.text.size();
  EXPECT_EQ(sent, 8100u);
  // One second later 1000 bytes of budget are back: the note about the drop comes first.
  t.addLine("a", "after", t0 + milliseconds(1000));
  due = t.takeDue(t0 + milliseconds(1000), true);
  ASSERT_EQ(due.size(), 1u);
  EXPECT_EQ(due[0].text,
            "[deputy: 19 lines not sent, over the output rate; see the log file]\nafter\n");
}

TEST(LaunchPlan, PlainCommandsRunWithoutAShell) {
  const LaunchPlan p = planLaunch("  evermap-vo-proc --config  config/vo.yaml\t-v ");
  EXPECT_FALSE(p.via_shell);
  EXPECT_EQ(p.argv,
            (std::vector<std::string>{"evermap-vo-proc", "--config", "config/vo.yaml", "-v"}));
  EXPECT_TRUE(p.env_assignments.empty());
}

TEST(LaunchPlan, LeadingAssignmentsSetTheEnvironment) {
  const LaunchPlan p =
      planLaunch("DISPLAY=:1.0 LCM_DEFAULT_URL=udpm://239.255.76.67:7667 xterm a=b");
  EXPECT_FALSE(p.via_shell);
  EXPECT_EQ(p.env_assignments, (std::vector<std::string>{
                                   "DISPLAY=:1.0", "LCM_DEFAULT_URL=udpm://239.255.76.67:7667"}));
  EXPECT_EQ(p.argv, (std::vector<std::string>{"xterm", "a=b"}));
}

TEST(LaunchPlan, ShellSyntaxGoesThroughSh) {
  for (const char* exec : {"ls ${HOME}", "a | b", "echo 'quoted'", "a; b", "a > log", "ls *.txt",
                           "cd ~", "X=1", "exit 3", "exec prog --x"}) {
    const LaunchPlan p = planLaunch(exec);
    EXPECT_TRUE(p.via_shell) << exec;
    EXPECT_EQ(p.argv, (std::vector<std::string>{"/bin/sh", "-c", exec}));
  }
}

TEST(ProcStat, ParsesNamesWithSpacesAndParentheses) {
  const std::string text =
      "4242 (my (odd) prog) S 1 4240 4240 0 -1 4194560 100 0 0 0 25 17 3 2 20 0 1 0 5 1000 50";
  auto s = parseProcStat(text);
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(s->pid, 4242);
  EXPECT_EQ(s->state, 'S');
  EXPECT_EQ(s->pgrp, 4240);
  EXPECT_EQ(s->cpu_ticks, 25 + 17 + 3 + 2);
  EXPECT_FALSE(parseProcStat("4242 (x) S 1 2").ok());
  EXPECT_FALSE(parseProcStat("garbage").ok());
}

TEST(ProcStat, ReadsThisProcessGroup) {
  std::ifstream f("/proc/self/stat");
  std::string text;
  std::getline(f, text);
  auto s = parseProcStat(text);
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(s->pid, ::getpid());
  EXPECT_EQ(s->pgrp, ::getpgrp());
  const auto usage = sampleGroups({::getpgrp()});
  ASSERT_EQ(usage.count(::getpgrp()), 1u);
  EXPECT_GE(usage.at(::getpgrp()).members, 1);
  EXPECT_GT(usage.at(::getpgrp()).rss_bytes, 1 << 20);  // a gtest binary holds more than 1 MiB
}

}  // namespace
}  // namespace evermap::deputy
