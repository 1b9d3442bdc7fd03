#pragma once
// Starting one supervised process: how an exec string becomes an argv, and fork/exec into a
// process group of its own with stdout and stderr on one pipe.
//
// An exec string without shell syntax ("prog --a 1 --b x", optionally preceded by NAME=VALUE
// environment assignments, as procman allows) is split on white space and executed directly,
// so the pid the deputy reports is the program's own. Anything else (quotes, $VAR, pipes,
// redirections, ';', globs, ~, a shell builtin such as exit or exec as the first word) runs
// as `/bin/sh -c EXEC`; start it with `exec` to have the shell replaced by the program. Either way
// the child leads a new process group, so a stop signal reaches everything it started.

#include <sys/types.h>

#include <string>
#include <string_view>
#include <vector>

#include "core/common/expected.h"

namespace evermap::deputy {

struct LaunchPlan {
  std::vector<std::string> argv;             // argv[0] is looked up in PATH
  std::vector<std::string> env_assignments;  // "NAME=VALUE", added to the deputy's environment
  bool via_shell = false;
};

LaunchPlan planLaunch(std::string_view exec);

// A started child. The deputy owns the file descriptors and closes them (closeFds()).
struct ChildHandle {
  pid_t pid = 0;       // also the process group id
  int output_fd = -1;  // read end of the stdout+stderr pipe, non-blocking
  int pid_fd = -1;     // pidfd (readable when the child ends), or -1 where unsupported
  void closeFds();
};

// Forks and executes the plan: stdin from /dev/null, stdout and stderr into one pipe, signal
// mask and dispositions reset, new process group. An exec failure (no such program,
// permission) is reported here as an error naming the program, with the child reaped.
Expected<ChildHandle> spawnChild(const LaunchPlan& plan);

// Sends `signal` to the whole process group of `pgid`; false when no member is left.
bool signalGroup(pid_t pgid, int signal);

}  // namespace evermap::deputy
