// posix_spawn does the fork/exec: it is safe in a process with threads (LCM may run one),
// reports exec failures as its return value, and sets the process group, signal mask and
// dispositions and the file descriptors in the child without code of ours running there.
#include "tools/deputy/child_process.h"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstring>

extern char** environ;

namespace evermap::deputy {
namespace {

bool isEnvName(std::string_view s) {
  if (s.empty() || !(std::isalpha(static_cast<unsigned char>(s[0])) || s[0] == '_')) return false;
  for (char c : s) {
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_')) return false;
  }
  return true;
}

// The deputy's environment with the plan's assignments applied (later ones win).
std::vector<std::string> childEnvironment(const std::vector<std::string>& assignments) {
  std::vector<std::string> env;
  for (char** e = environ; e && *e; ++e) env.emplace_back(*e);
  for (const std::string& a : assignments) {
    const std::string name = a.substr(0, a.find('=') + 1);
    bool replaced = false;
    for (std::string& e : env) {
      if (e.compare(0, name.size(), name) == 0) {
        e = a;
        replaced = true;
      }
    }
    if (!replaced) env.push_back(a);
  }
  return env;
}

std::vector<char*> pointers(std::vector<std::string>& strings) {
  std::vector<char*> p;
  for (std::string& s : strings) p.push_back(s.data());
  p.push_back(nullptr);
  return p;
}

// The PATH the child will search: its own environment's.
std::string pathOf(const std::vector<std::string>& env) {
  for (const std::string& e : env) {
    if (e.compare(0, 5, "PATH=") == 0) return e.substr(5);
  }
  return "/usr/local/bin:/usr/bin:/bin";
}

// posix_spawnp searches the deputy's PATH, not the child's; resolve with the child's.
std::string resolveProgram(const std::string& program, const std::string& path) {
  if (program.find('/') != std::string::npos) return program;
  size_t start = 0;
  while (start <= path.size()) {
    const size_t end = std::min(path.find(':', start), path.size());
    const std::string dir = end > start ? path.substr(start, end - start) : ".";
    const std::string candidate = dir + "/" + program;
    if (::access(candidate.c_str(), X_OK) == 0) return candidate;
    start = end + 1;
  }
  return "";
}

}  // namespace

LaunchPlan planLaunch(std::string_view exec) {
  LaunchPlan plan;
  // Characters that mean something to the shell: quoting, expansion, redirection, control.
  constexpr std::string_view kShellSyntax = "|&;<>()$`\\\"'*?[]#~{}!\n";
  const bool needs_shell = exec.find_first_of(kShellSyntax) != std::string_view::npos;
  if (!needs_shell) {
    size_t i = 0;
    while (i < exec.size()) {
      while (i < exec.size() && (exec[i] == ' ' || exec[i] == '\t')) ++i;
      const size_t start = i;
      while (i < exec.size() && exec[i] != ' ' && exec[i] != '\t') ++i;
      if (i == start) break;
      std::string word(exec.substr(start, i - start));
      const size_t eq = word.find('=');
      if (plan.argv.empty() && eq != std::string::npos && isEnvName(word.substr(0, eq))) {
        plan.env_assignments.push_back(std::move(word));
      } else {
        plan.argv.push_back(std::move(word));
      }
    }
    // A shell builtin ("exit 3", "exec prog", "cd dir") only means something to a shell.
    static constexpr std::string_view kBuiltins[] = {
        ".",      "alias",   "break", "cd",    "command", "continue", "eval",    "exec",  "exit",
        "export", "getopts", "hash",  "local", "read",    "readonly", "return",  "set",   "shift",
        "source", "times",   "trap",  "type",  "ulimit",  "umask",    "unalias", "unset", "wait"};
    const bool builtin = !plan.argv.empty() && std::find(std::begin(kBuiltins), std::end(kBuiltins),
                                                         plan.argv[0]) != std::end(kBuiltins);
    if (!plan.argv.empty() && !builtin) return plan;
  }
  plan = LaunchPlan{};
  plan.via_shell = true;
  plan.argv = {"/bin/sh", "-c", std::string(exec)};
  return plan;
}

void ChildHandle::closeFds() {
  if (output_fd >= 0) ::close(output_fd);
  if (pid_fd >= 0) ::close(pid_fd);
  output_fd = -1;
  pid_fd = -1;
}

Expected<ChildHandle> spawnChild(const LaunchPlan& plan) {
  if (plan.argv.empty()) return makeError("empty command");
  std::vector<std::string> env = childEnvironment(plan.env_assignments);
  const std::string program = resolveProgram(plan.argv[0], pathOf(env));
  if (program.empty()) {
    return makeError("cannot execute '", plan.argv[0], "': not found in PATH");
  }
  int out[2];
  if (::pipe2(out, O_CLOEXEC) != 0) return makeError("pipe: ", std::strerror(errno));

  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_adddup2(&actions, out[1], 1);
  posix_spawn_file_actions_adddup2(&actions, out[1], 2);
  // Nothing of the deputy's (LCM socket, log files, other children's pipes) leaks into it.
  posix_spawn_file_actions_addclosefrom_np(&actions, 3);

  posix_spawnattr_t attr;
  posix_spawnattr_init(&attr);
  posix_spawnattr_setflags(&attr,
                           POSIX_SPAWN_SETPGROUP | POSIX_SPAWN_SETSIGMASK | POSIX_SPAWN_SETSIGDEF);
  posix_spawnattr_setpgroup(&attr, 0);  // leads a new group whose id is its pid
  sigset_t none;
  sigemptyset(&none);
  posix_spawnattr_setsigmask(&attr, &none);  // the deputy blocks SIGINT/SIGTERM for signalfd
  sigset_t all;
  sigfillset(&all);
  sigdelset(&all, SIGKILL);
  sigdelset(&all, SIGSTOP);
  posix_spawnattr_setsigdefault(&attr, &all);

  std::vector<std::string> args = plan.argv;
  std::vector<char*> argv = pointers(args);
  std::vector<char*> envp = pointers(env);
  pid_t pid = 0;
  const int rc = ::posix_spawn(&pid, program.c_str(), &actions, &attr, argv.data(), envp.data());
  posix_spawn_file_actions_destroy(&actions);
  posix_spawnattr_destroy(&attr);
  ::close(out[1]);
  if (rc != 0) {
    ::close(out[0]);
    return makeError("cannot execute '", program, "': ", std::strerror(rc));
  }
  ChildHandle child;
  child.pid = pid;
  child.output_fd = out[0];
  ::fcntl(child.output_fd, F_SETFL, ::fcntl(child.output_fd, F_GETFL) | O_NONBLOCK);
#ifdef SYS_pidfd_open
  child.pid_fd = static_cast<int>(::syscall(SYS_pidfd_open, pid, 0));
  if (child.pid_fd >= 0) ::fcntl(child.pid_fd, F_SETFD, FD_CLOEXEC);
#endif
  return child;
}

bool signalGroup(pid_t pgid, int signal) {
  if (pgid <= 0) return false;
  return ::kill(-pgid, signal) == 0 || errno != ESRCH;
}

}  // namespace evermap::deputy
