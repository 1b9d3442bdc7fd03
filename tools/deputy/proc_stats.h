#pragma once
// CPU time and resident memory of supervised process groups, read from /proc (proc(5)).
//
// A supervised command may be a shell that starts the real program, so usage is summed over
// every live member of its process group: utime + stime + cutime + cstime from
// /proc/<pid>/stat (fields 14-17, clock ticks; the c* fields hold members already reaped by
// other members) and resident pages from /proc/<pid>/statm (field 2).

#include <sys/types.h>

#include <cstdint>
#include <map>
#include <set>
#include <string>

#include "core/common/expected.h"

namespace evermap::deputy {

struct ProcStat {
  pid_t pid = 0;
  pid_t pgrp = 0;
  char state = '?';       // R, S, D, Z, ...
  int64_t cpu_ticks = 0;  // utime + stime + cutime + cstime
};

// Parses the text of /proc/<pid>/stat. The command name (field 2) is in parentheses and may
// hold spaces and parentheses itself, so fields are counted after the last ')'.
Expected<ProcStat> parseProcStat(const std::string& text);

struct GroupUsage {
  int64_t cpu_ticks = 0;
  int64_t rss_bytes = 0;
  int members = 0;
};

// One pass over /proc: usage of each group in `pgids` that has live members.
std::map<pid_t, GroupUsage> sampleGroups(const std::set<pid_t>& pgids);

// Clock ticks per second (sysconf(_SC_CLK_TCK)).
double ticksPerSecond();

}  // namespace evermap::deputy
