#include "tools/deputy/proc_stats.h"

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

namespace evermap::deputy {

Expected<ProcStat> parseProcStat(const std::string& text) {
  const size_t close = text.rfind(')');
  const size_t open = text.find('(');
  if (open == std::string::npos || close == std::string::npos || close < open) {
    return makeError("/proc stat: no command name in parentheses");
  }
  ProcStat s;
  s.pid = static_cast<pid_t>(std::atol(text.substr(0, open).c_str()));
  std::istringstream rest(text.substr(close + 1));
  // Field 3 is the state; fields 4.. follow. We need 5 (pgrp) and 14-17 (times).
  std::vector<std::string> f;
  std::string word;
  while (f.size() < 15 && rest >> word) f.push_back(word);
  if (f.size() < 15 || f[0].size() != 1) return makeError("/proc stat: too few fields");
  s.state = f[0][0];
  char* end = nullptr;
  s.pgrp = static_cast<pid_t>(std::strtol(f[2].c_str(), &end, 10));  // field 5
  if (*end != '\0') return makeError("/proc stat: bad pgrp '", f[2], "'");
  for (int i = 11; i <= 14; ++i) {  // fields 14..17
    const long long v = std::strtoll(f[i].c_str(), &end, 10);
    if (*end != '\0' || v < 0) return makeError("/proc stat: bad time field '", f[i], "'");
    s.cpu_ticks += v;
  }
  return s;
}

double ticksPerSecond() {
  const long t = ::sysconf(_SC_CLK_TCK);
  return t > 0 ? static_cast<double>(t) : 100.0;
}

std::map<pid_t, GroupUsage> sampleGroups(const std::set<pid_t>& pgids) {
  std::map<pid_t, GroupUsage> usage;
  if (pgids.empty()) return usage;
  const long page = ::sysconf(_SC_PAGESIZE);
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator("/proc", ec)) {
    const std::string name = entry.path().filename().string();
    if (name.empty() || name.find_first_not_of("0123456789") != std::string::npos) continue;
    // A process may end between listing and reading: a failed read just skips it.
    std::ifstream stat_file(entry.path() / "stat");
    std::string text;
    if (!std::getline(stat_file, text)) continue;
    const auto stat = parseProcStat(text);
    if (!stat || !pgids.count(stat->pgrp) || stat->state == 'Z') continue;
    GroupUsage& g = usage[stat->pgrp];
    g.cpu_ticks += stat->cpu_ticks;
    ++g.members;
    std::ifstream statm(entry.path() / "statm");
    long long size_pages = 0, resident_pages = 0;
    if (statm >> size_pages >> resident_pages) g.rss_bytes += resident_pages * page;
  }
  return usage;
}

}  // namespace evermap::deputy
