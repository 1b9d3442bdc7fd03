#pragma once
// Helpers for the deputy tests with real child processes: run the supervisor's loop until a
// condition holds (a generous time-out only guards against a hang, it asserts no speed),
// read a log file, check that a process is gone.

#include <poll.h>
#include <signal.h>

#include <cerrno>
#include <chrono>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <thread>

#include "tools/deputy/supervisor.h"

namespace evermap::deputy::testing {

constexpr double kGenerousTimeoutS = 60.0;

inline bool spinUntil(Supervisor& s, const std::function<bool()>& done,
                      double timeout_s = kGenerousTimeoutS) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (std::chrono::steady_clock::now() < end) {
    if (done()) return true;
    std::vector<pollfd> fds;
    s.appendPollFds(&fds);
    const auto wait = std::chrono::ceil<std::chrono::milliseconds>(
        std::min(s.nextDeadline(),
                 std::chrono::steady_clock::now() + std::chrono::milliseconds(50)) -
        std::chrono::steady_clock::now());
    ::poll(fds.data(), fds.size(), static_cast<int>(std::max<int64_t>(0, wait.count())));
    s.service();
  }
  return done();
}

inline std::string readFile(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

inline int countOf(const std::string& text, const std::string& what) {
  int n = 0;
  for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

// True once no process `pid` exists (a killed orphan is reaped by init shortly after).
inline bool gone(pid_t pid, double timeout_s = kGenerousTimeoutS) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (true) {
    if (::kill(pid, 0) != 0 && errno == ESRCH) return true;
    if (std::chrono::steady_clock::now() > end) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
}

inline bool groupGone(pid_t pgid, double timeout_s = kGenerousTimeoutS) {
  return gone(-pgid, timeout_s);
}

inline CommandSpec command(const std::string& name, const std::string& exec) {
  CommandSpec c;
  c.name = name;
  c.exec = exec;
  return c;
}

// command() with auto_respawn: started again after each end, after the back-off.
inline CommandSpec respawning(const std::string& name, const std::string& exec) {
  CommandSpec c = command(name, exec);
  c.auto_respawn = true;
  return c;
}

}  // namespace evermap::deputy::testing
