// The evermap-deputy program as a separate process: SIGTERM stops every child and the deputy
// exits 0 with no orphan left; a malformed configuration is refused naming file:line:column.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>

#include <cstring>
#include <fstream>

#include "deputy_test_util.h"
#include "scratch_dir.h"

extern char** environ;

namespace evermap::deputy {
namespace {

using testing::readFile;

const std::filesystem::path kDeputy =
    std::filesystem::path(EVERMAP_BINARY_DIR) / "bin" / "evermap-deputy";

// Starts the deputy with `args`, its stderr into `stderr_file`.
pid_t startDeputy(const std::vector<std::string>& args, const std::filesystem::path& stderr_file) {
  std::vector<std::string> all = {kDeputy.string()};
  all.insert(all.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : all) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, 2, stderr_file.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  pid_t pid = 0;
  const int rc = posix_spawn(&pid, argv[0], &fa, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&fa);
  EXPECT_EQ(rc, 0) << kDeputy << ": " << std::strerror(rc);
  return rc == 0 ? pid : 0;
}

int waitExit(pid_t pid) {
  int status = 0;
  EXPECT_EQ(::waitpid(pid, &status, 0), pid);
  EXPECT_TRUE(WIFEXITED(status)) << "status " << status;
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

bool waitForFile(const std::filesystem::path& p) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (std::chrono::steady_clock::now() < end) {
    if (readFile(p).find('\n') != std::string::npos) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return false;
}

TEST(DeputyProgram, SigtermStopsEveryChildAndLeavesNoOrphan) {
  ASSERT_TRUE(std::filesystem::exists(kDeputy)) << kDeputy << " not built";
  evermap::testing::ScratchDir dir;
  const std::string d = dir.path().string();
  std::ofstream(dir / "test.pmd")
      << "cmd \"sleeper\" { exec = \"echo $$ > " << d << "/sleeper.pid; exec sleep 1000\"; }\n"
      << "cmd \"stubborn\" {\n"
      << "  exec = \"trap '' INT TERM; echo $$ > " << d << "/stubborn.pid; "
      << "sleep 1000 & echo $! > " << d << "/stubborn-child.pid; while :; do sleep 0.05; done\";\n"
      << "  stop_signal = 15; stop_time_allowed = 1;\n}\n"
      << "group \"g\" {\n"
      << "  cmd \"respawner\" { exec = \"echo $$ > " << d << "/respawner.pid; sleep 1000\"; "
      << "auto_respawn = \"true\"; }\n"
      << "  cmd \"crasher\" { exec = \"exit 1\"; auto_respawn = \"true\"; }\n"
      << "}\n";
  const pid_t deputy =
      startDeputy({(dir / "test.pmd").string(), "--log-dir", d + "/logs", "--start-all",
                   "--lcm-url", "memq://", "--backoff-initial-ms", "20"},
                  dir / "stderr.txt");
  ASSERT_GT(deputy, 0);
  std::vector<pid_t> children;
  for (const char* f : {"sleeper.pid", "stubborn.pid", "stubborn-child.pid", "respawner.pid"}) {
    ASSERT_TRUE(waitForFile(dir / f)) << f << "\n" << readFile(dir / "stderr.txt");
    children.push_back(std::stoi(readFile(dir / f)));
  }
  ASSERT_EQ(::kill(deputy, SIGTERM), 0);
  EXPECT_EQ(waitExit(deputy), 0) << readFile(dir / "stderr.txt");
  for (pid_t p : children) EXPECT_TRUE(testing::gone(p)) << "pid " << p << " outlived the deputy";
  const std::string err = readFile(dir / "stderr.txt");
  EXPECT_NE(err.find("Terminated: stopping every process"), std::string::npos) << err;
  EXPECT_NE(err.find("evermap-deputy: all stopped"), std::string::npos) << err;
  EXPECT_NE(readFile(dir / "logs" / "stubborn.log").find("SIGKILL"), std::string::npos);
}

TEST(DeputyProgram, RefusesAMalformedConfigNamingTheLine) {
  ASSERT_TRUE(std::filesystem::exists(kDeputy)) << kDeputy << " not built";
  evermap::testing::ScratchDir dir;
  std::ofstream(dir / "bad.pmd") << "cmd \"a\" {\n  exec = \"x\";\n  auto_respawn = true;\n}\n";
  const pid_t deputy = startDeputy(
      {(dir / "bad.pmd").string(), "--log-dir", (dir / "logs").string(), "--lcm-url", "memq://"},
      dir / "stderr.txt");
  ASSERT_GT(deputy, 0);
  EXPECT_EQ(waitExit(deputy), 2);
  EXPECT_EQ(readFile(dir / "stderr.txt"),
            "evermap-deputy: " + (dir / "bad.pmd").string() +
                ":3:18: expected a string or an integer for auto_respawn, got a word (true)\n");
}

TEST(DeputyProgram, ExitsAfterItsScriptWhenAsked) {
  ASSERT_TRUE(std::filesystem::exists(kDeputy)) << kDeputy << " not built";
  evermap::testing::ScratchDir dir;
  std::ofstream(dir / "run.pmd") << "cmd \"server\" { exec = \"sleep 1000\"; }\n"
                                 << "cmd \"job\" { exec = \"echo job-done\"; }\n"
                                 << "script \"run\" {\n  start cmd \"server\" wait \"running\";\n"
                                 << "  start cmd \"job\" wait \"stopped\";\n}\n";
  const pid_t deputy =
      startDeputy({(dir / "run.pmd").string(), "--log-dir", (dir / "logs").string(), "--lcm-url",
                   "memq://", "--script", "run", "--exit-after-script"},
                  dir / "stderr.txt");
  ASSERT_GT(deputy, 0);
  EXPECT_EQ(waitExit(deputy), 0) << readFile(dir / "stderr.txt");
  EXPECT_NE(readFile(dir / "logs" / "job.log").find("job-done\n"), std::string::npos);
  EXPECT_NE(readFile(dir / "logs" / "server.log").find("ended: killed by signal 2"),
            std::string::npos)
      << readFile(dir / "logs" / "server.log");
}

}  // namespace
}  // namespace evermap::deputy
