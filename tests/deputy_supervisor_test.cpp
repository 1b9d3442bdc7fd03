// The supervisor with real child processes (/bin/sh, sleep): logs, restarts with back-off,
// stop escalation, start delay, shutdown without orphans. No test asserts an upper time
// limit; waits have a generous time-out against hangs only.
#include <gtest/gtest.h>

#include <signal.h>

#include <fstream>

#include "deputy_test_util.h"
#include "scratch_dir.h"
#include "tools/deputy/supervisor.h"

namespace evermap::deputy {
namespace {

using testing::command;
using testing::countOf;
using testing::gone;
using testing::readFile;
using testing::respawning;
using testing::spinUntil;
using Clock = std::chrono::steady_clock;

std::unique_ptr<Supervisor> makeSupervisor(std::vector<CommandSpec> commands,
                                           const std::filesystem::path& log_dir,
                                           BackoffOptions backoff = {}) {
  SupervisorOptions o;
  o.log_dir = log_dir;
  o.backoff = backoff;
  auto s = Supervisor::create(std::move(commands), o);
  EXPECT_TRUE(s.ok()) << (s.ok() ? "" : s.error().message);
  return s.ok() ? std::move(*s) : nullptr;
}

// A back-off from 50 ms (the tests wait for the restarts), stable after `stable_after_s`.
BackoffOptions quickBackoff(double stable_after_s) {
  BackoffOptions b;
  b.initial_delay_ms = 50;
  b.stable_after_s = stable_after_s;
  return b;
}

// Whether `file` holds a whole line yet (a pid a command wrote).
bool hasALine(const std::filesystem::path& file) {
  return readFile(file).find('\n') != std::string::npos;
}

// Spins `s` until `file` holds a whole line.
bool spinUntilALine(Supervisor& s, const std::filesystem::path& file) {
  return spinUntil(s, [&] { return hasALine(file); });
}

// Starts `name` and spins the supervisor until the command has ended.
void runToTheEnd(Supervisor& s, const std::string& name) {
  ASSERT_TRUE(s.start(name).ok());
  ASSERT_TRUE(spinUntil(s, [&] { return s.status(name)->has_ended; }));
}

TEST(DeputySupervisor, WritesStdoutAndStderrToTheProcessLogAndTheSink) {
  evermap::testing::ScratchDir dir;
  auto s = makeSupervisor(
      {command("talker", "echo out-line; echo err-line >&2; printf 'no newline'")}, dir / "logs");
  std::vector<std::string> lines;
  s->setLineSink([&](const std::string& name, const std::string& line, bool from_deputy) {
    EXPECT_EQ(name, "talker");
    if (!from_deputy) lines.push_back(line);
  });
  ASSERT_NO_FATAL_FAILURE(runToTheEnd(*s, "talker"));
  EXPECT_EQ(s->status("talker")->state, ProcessState::kStopped);  // exit 0 without respawn
  EXPECT_EQ(s->status("talker")->last_exit_code, 0);
  EXPECT_EQ(lines, (std::vector<std::string>{"out-line", "err-line", "no newline"}));
  const std::string log = readFile(dir / "logs" / "talker.log");
  EXPECT_NE(log.find("out-line\nerr-line\nno newline\n"), std::string::npos) << log;
  EXPECT_NE(log.find("] started pid "), std::string::npos) << log;
  EXPECT_NE(log.find("] ended: exit code 0"), std::string::npos) << log;
}

TEST(DeputySupervisor, RotatesALogFileThatGrowsTooBig) {
  evermap::testing::ScratchDir dir;
  SupervisorOptions o;
  o.log_dir = dir.path();
  o.max_log_bytes = 4000;
  // 300 lines of 100 bytes: 30000 bytes, rotated every ~4000.
  auto s = Supervisor::create(
      {command("chatty", "i=0; while [ $i -lt 300 ]; do printf '%099d\\n' $i; i=$((i+1)); done")},
      o);
  ASSERT_TRUE(s.ok()) << s.error().message;
  ASSERT_NO_FATAL_FAILURE(runToTheEnd(**s, "chatty"));
  EXPECT_EQ((*s)->status("chatty")->last_exit_code, 0);
  const auto current = std::filesystem::file_size(dir / "chatty.log");
  const auto previous = std::filesystem::file_size(dir / "chatty.log.1");
  EXPECT_LT(current, 4000u + 16384u);  // one read's worth may follow the limit
  EXPECT_GE(previous, 4000u);
  // The newest lines are in the two files, whole; the oldest went with earlier rotations.
  const std::string both = readFile(dir / "chatty.log.1") + readFile(dir / "chatty.log");
  EXPECT_NE(both.find("\n" + std::string(96, '0') + "299\n"), std::string::npos);
  EXPECT_EQ(both.find(std::string(99, '0') + "\n"), std::string::npos);  // line 0
}

TEST(DeputySupervisor, LogFileNamesAreSafe) {
  evermap::testing::ScratchDir dir;
  auto s = makeSupervisor({command("../odd name/x", "true")}, dir.path());
  EXPECT_EQ(s->logFile("../odd name/x"), dir / "_.._odd_name_x.log");
}

TEST(DeputySupervisor, RestartsACrashingCommandWithGrowingBackoff) {
  evermap::testing::ScratchDir dir;
  BackoffOptions b = quickBackoff(30);
  b.factor = 2;
  b.max_delay_ms = 400;
  auto s = makeSupervisor({respawning("crasher", "echo crash; exit 3")}, dir.path(), b);
  std::vector<std::pair<std::string, Clock::time_point>> notes;
  s->setLineSink([&](const std::string&, const std::string& line, bool from_deputy) {
    if (from_deputy) notes.emplace_back(line, Clock::now());
  });
  ASSERT_TRUE(s->start("crasher").ok());
  ASSERT_TRUE(spinUntil(*s, [&] { return s->status("crasher")->restarts >= 5; }));
  const ProcessStatus st = *s->status("crasher");
  EXPECT_EQ(st.last_exit_code, 3);
  EXPECT_EQ(st.starts, st.restarts + 1);
  EXPECT_GE(countOf(readFile(dir / "crasher.log"), "crash\n"), 5);
  // Each restart came no sooner than its back-off after the end before it: 50, 100, 200,
  // 400, 400 ms.
  const std::vector<double> expected_ms = {50, 100, 200, 400, 400};
  std::vector<double> gaps_ms;
  for (size_t i = 0; i + 1 < notes.size(); ++i) {
    if (notes[i].first.rfind("ended:", 0) == 0 &&
        notes[i + 1].first.find("restarting in") != std::string::npos) {
      // The restart note follows the end; the restart itself is the next "restarted" note.
      for (size_t j = i + 2; j < notes.size(); ++j) {
        if (notes[j].first.rfind("restarted pid", 0) == 0) {
          gaps_ms.push_back(
              std::chrono::duration<double, std::milli>(notes[j].second - notes[i].second).count());
          break;
        }
      }
    }
  }
  ASSERT_GE(gaps_ms.size(), 5u);
  for (size_t i = 0; i < 5; ++i) EXPECT_GE(gaps_ms[i], expected_ms[i]) << "restart " << i + 1;
  EXPECT_NE(readFile(dir / "crasher.log").find("auto_respawn: restarting in 400 ms"),
            std::string::npos);
}

TEST(DeputySupervisor, StableRunsResetTheBackoff) {
  evermap::testing::ScratchDir dir;
  // Every 0.4 s run counts as stable.
  auto s = makeSupervisor({respawning("slow-crasher", "sleep 0.4; exit 1")}, dir.path(),
                          quickBackoff(0.3));
  ASSERT_TRUE(s->start("slow-crasher").ok());
  ASSERT_TRUE(spinUntil(*s, [&] { return s->status("slow-crasher")->restarts >= 3; }));
  EXPECT_DOUBLE_EQ(s->status("slow-crasher")->last_backoff_ms, 50.0);
}

TEST(DeputySupervisor, WithoutAutoRespawnAFailedCommandStaysFailed) {
  evermap::testing::ScratchDir dir;
  auto s = makeSupervisor({command("once", "exit 7")}, dir.path());
  ASSERT_NO_FATAL_FAILURE(runToTheEnd(*s, "once"));
  const ProcessStatus st = *s->status("once");
  EXPECT_EQ(st.state, ProcessState::kFailed);
  EXPECT_EQ(st.last_exit_code, 7);
  EXPECT_EQ(st.restarts, 0);
  EXPECT_TRUE(st.desired_running);  // procman: still "should run"; a new start order reruns it
  ASSERT_TRUE(s->start("once").ok());
  ASSERT_TRUE(spinUntil(*s, [&] {
    return s->status("once")->starts == 2 && s->status("once")->pid == 0 &&
           s->status("once")->state == ProcessState::kFailed;
  }));
}

TEST(DeputySupervisor, StopEscalatesToSigkillAfterStopTimeAllowed) {
  evermap::testing::ScratchDir dir;
  CommandSpec stubborn =
      command("stubborn", "trap '' INT TERM; echo ready; while :; do sleep 0.05; done");
  stubborn.stop_signal = SIGTERM;
  stubborn.stop_time_allowed_s = 1;
  auto s = makeSupervisor({stubborn}, dir.path());
  ASSERT_TRUE(s->start("stubborn").ok());
  ASSERT_TRUE(spinUntil(
      *s, [&] { return readFile(dir / "stubborn.log").find("ready\n") != std::string::npos; }));
  const pid_t pid = s->status("stubborn")->pid;
  ASSERT_GT(pid, 0);
  const auto stop_at = Clock::now();
  ASSERT_TRUE(s->stop("stubborn").ok());
  EXPECT_EQ(s->status("stubborn")->state, ProcessState::kStopping);
  ASSERT_TRUE(
      spinUntil(*s, [&] { return s->status("stubborn")->state == ProcessState::kStopped; }));
  // SIGTERM was ignored; SIGKILL came, and not before stop_time_allowed had passed.
  EXPECT_GE(Clock::now() - stop_at, std::chrono::seconds(1));
  EXPECT_EQ(s->status("stubborn")->last_exit_code, -SIGKILL);
  EXPECT_FALSE(s->status("stubborn")->desired_running);
  EXPECT_TRUE(gone(pid));
  EXPECT_TRUE(testing::groupGone(pid));  // its sleep children too
  const std::string log = readFile(dir / "stubborn.log");
  EXPECT_NE(log.find("stopping: signal 15"), std::string::npos) << log;
  EXPECT_NE(log.find("after the stop signal: SIGKILL"), std::string::npos) << log;
}

TEST(DeputySupervisor, StopSignalReachesTheWholeProcessGroup) {
  evermap::testing::ScratchDir dir;
  // The shell waits on two sleeps; the stop signal must reach them, not only the shell.
  auto s = makeSupervisor(
      {command("pair", "sleep 1000 & echo $! > " + (dir / "child.pid").string() + "; sleep 1000")},
      dir.path());
  ASSERT_TRUE(s->start("pair").ok());
  ASSERT_TRUE(spinUntilALine(*s, dir / "child.pid"));
  const pid_t child = std::stoi(readFile(dir / "child.pid"));
  ASSERT_TRUE(s->stop("pair").ok());
  ASSERT_TRUE(spinUntil(*s, [&] { return s->status("pair")->state == ProcessState::kStopped; }));
  EXPECT_TRUE(gone(child));
}

TEST(DeputySupervisor, RestartOrderGivesANewProcess) {
  evermap::testing::ScratchDir dir;
  auto s = makeSupervisor({command("sleeper", "sleep 1000")}, dir.path());
  ASSERT_TRUE(s->start("sleeper").ok());
  ASSERT_TRUE(spinUntil(*s, [&] { return s->status("sleeper")->state == ProcessState::kRunning; }));
  const pid_t first = s->status("sleeper")->pid;
  ASSERT_TRUE(s->restart("sleeper").ok());
  ASSERT_TRUE(spinUntil(*s, [&] {
    return s->status("sleeper")->starts == 2 &&
           s->status("sleeper")->state == ProcessState::kRunning;
  }));
  EXPECT_NE(s->status("sleeper")->pid, first);
  EXPECT_EQ(s->status("sleeper")->restarts, 0);  // ordered, not automatic
  EXPECT_TRUE(gone(first));
}

TEST(DeputySupervisor, StartDelayHoldsTheStart) {
  evermap::testing::ScratchDir dir;
  CommandSpec c = command("late", "sleep 1000");
  c.start_delay_ms = 300;
  auto s = makeSupervisor({c}, dir.path());
  const auto ordered = Clock::now();
  ASSERT_TRUE(s->start("late").ok());
  EXPECT_EQ(s->status("late")->state, ProcessState::kWaiting);
  ASSERT_TRUE(spinUntil(*s, [&] { return s->status("late")->state == ProcessState::kRunning; }));
  EXPECT_GE(Clock::now() - ordered, std::chrono::milliseconds(300));
  // A stop while waiting cancels the start.
  ASSERT_TRUE(s->restart("late").ok());
  ASSERT_TRUE(s->stop("late").ok());
  ASSERT_TRUE(spinUntil(*s, [&] { return s->status("late")->state == ProcessState::kStopped; }));
  EXPECT_EQ(s->status("late")->starts, 1);
}

TEST(DeputySupervisor, AMissingProgramIsReportedAsFailed) {
  evermap::testing::ScratchDir dir;
  auto s = makeSupervisor({command("ghost", "/nonexistent/evermap-ghost --x")}, dir.path());
  ASSERT_NO_FATAL_FAILURE(runToTheEnd(*s, "ghost"));
  EXPECT_EQ(s->status("ghost")->state, ProcessState::kFailed);
  EXPECT_EQ(s->status("ghost")->last_exit_code, 127);
  EXPECT_NE(readFile(dir / "ghost.log").find("cannot execute '/nonexistent/evermap-ghost'"),
            std::string::npos);
  EXPECT_FALSE(s->start("nobody").ok());
}

TEST(DeputySupervisor, ShutdownStopsEveryChildIncludingStubbornOnes) {
  evermap::testing::ScratchDir dir;
  CommandSpec stubborn =
      command("stubborn", "trap '' INT TERM; echo $$ > " + (dir / "s.pid").string() +
                              "; while :; do sleep 0.05; done");
  stubborn.stop_time_allowed_s = 1;
  auto s = makeSupervisor(
      {command("sleeper", "sleep 1000"), stubborn, respawning("respawner", "sleep 1000")},
      dir.path());
  for (const char* n : {"sleeper", "stubborn", "respawner"}) ASSERT_TRUE(s->start(n).ok());
  ASSERT_TRUE(spinUntil(*s, [&] {
    for (const auto& st : s->status()) {
      if (st.state != ProcessState::kRunning) return false;
    }
    return hasALine(dir / "s.pid");
  }));
  std::vector<pid_t> pids;
  for (const auto& st : s->status()) pids.push_back(st.pid);
  s->beginShutdown();
  EXPECT_FALSE(s->start("sleeper").ok());
  ASSERT_TRUE(spinUntil(*s, [&] { return s->allStopped(); }));
  for (const auto& st : s->status()) {
    EXPECT_EQ(st.state, ProcessState::kStopped) << st.name;
    EXPECT_EQ(st.restarts, 0) << st.name << ": auto_respawn must not restart during shutdown";
  }
  for (pid_t p : pids) EXPECT_TRUE(gone(p)) << p;
}

TEST(DeputySupervisor, DestroyingTheSupervisorLeavesNoChild) {
  evermap::testing::ScratchDir dir;
  pid_t pid = 0, grandchild = 0;
  {
    auto s = makeSupervisor(
        {command("family", "sleep 1000 & echo $! > " + (dir / "g.pid").string() + "; wait")},
        dir.path());
    ASSERT_TRUE(s->start("family").ok());
    ASSERT_TRUE(spinUntilALine(*s, dir / "g.pid"));
    pid = s->status("family")->pid;
    grandchild = std::stoi(readFile(dir / "g.pid"));
  }
  EXPECT_TRUE(gone(pid));
  EXPECT_TRUE(gone(grandchild));
}

TEST(DeputySupervisor, MeasuresCpuAndMemoryOfTheProcessGroup) {
  evermap::testing::ScratchDir dir;
  auto s = makeSupervisor({command("busy", "while :; do :; done"), command("idle", "sleep 1000")},
                          dir.path());
  ASSERT_TRUE(s->start("busy").ok());
  ASSERT_TRUE(s->start("idle").ok());
  ASSERT_TRUE(spinUntil(*s, [&] {
    return s->status("busy")->state == ProcessState::kRunning &&
           s->status("idle")->state == ProcessState::kRunning;
  }));
  s->sampleUsage();
  // On a loaded machine the loop gets less than a core; it gets some, the sleeper none.
  ASSERT_TRUE(spinUntil(*s, [&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    s->sampleUsage();
    return s->status("busy")->cpu_percent > 5.0;
  }));
  EXPECT_LT(s->status("busy")->cpu_percent, 110.0);  // one single-threaded shell
  EXPECT_LT(s->status("idle")->cpu_percent, 5.0);
  EXPECT_GT(s->status("busy")->rss_bytes, 0);
  EXPECT_GT(s->status("idle")->rss_bytes, 0);
  ASSERT_TRUE(s->stop("busy").ok());
  ASSERT_TRUE(spinUntil(*s, [&] { return s->status("busy")->state == ProcessState::kStopped; }));
  s->sampleUsage();
  EXPECT_EQ(s->status("busy")->cpu_percent, 0.0);
  EXPECT_EQ(s->status("busy")->rss_bytes, 0);
}

TEST(DeputySupervisor, RefusesABadLogFolder) {
  evermap::testing::ScratchDir dir;
  std::ofstream(dir / "file") << "x";
  SupervisorOptions o;
  o.log_dir = dir / "file" / "logs";
  auto s = Supervisor::create({command("a", "true")}, o);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find((dir / "file" / "logs").string()), std::string::npos);
}

}  // namespace
}  // namespace evermap::deputy
