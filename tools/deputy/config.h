#pragma once
// A deputy configuration: bot-procman's sheriff config format (libbot2, bot2-procman
// doc/content/config_file.md), read unchanged, plus one evermap attribute (start_delay_ms).
//
//   # comment to the end of the line
//   cmd "name" { exec = "prog --flag"; host = "robot"; auto_respawn = "true";
//                stop_signal = 15; stop_time_allowed = 7; start_delay_ms = 500; }
//   group "g" { cmd "a" { ... }  group "sub" { cmd "b" { ... } } }   # "b" is in "g/sub"
//   script "go" {
//     start cmd "a" wait "running";        # start|stop|restart  cmd|group "X" | everything
//     wait ms 1000;
//     wait group "g/sub" status "stopped";
//     run_script "other";
//   }
//
// Values are quoted strings (escapes \n \r \t \\ \") or non-negative integers. Defaults are
// procman's: auto_respawn "false", stop_signal 2 (SIGINT), stop_time_allowed 7 s. A command
// without a name takes its exec string as name, as procman's sheriff does. Groups named in
// scripts are slash-joined paths ("hardware/cameras"); a group's commands include those of
// its subgroups. Every error names "file:line:column: what".

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "core/common/expected.h"

namespace evermap::deputy {

// Where a construct starts in its file: 1-based line and column (a tab counts as one).
struct SourcePos {
  int line = 0;
  int column = 0;
};

struct CommandSpec {
  std::string name;
  std::string exec;             // shell-style command line
  std::string host;             // the deputy that runs it; "" or "localhost": any deputy
  std::string group;            // slash-joined path of enclosing groups; "" at top level
  bool auto_respawn = false;    // restart when it ends while it should be running
  int stop_signal = 2;          // sent first when stopping (2 = SIGINT, procman's default)
  int stop_time_allowed_s = 7;  // then SIGKILL after this many seconds
  int start_delay_ms = 0;       // evermap addition: wait this long after a start order
  SourcePos pos;
};

enum class TargetKind { kEverything, kCommand, kGroup };
enum class WaitFor { kNothing, kRunning, kStopped };

struct ScriptAction {
  enum class Kind { kStart, kStop, kRestart, kWaitMs, kWaitStatus, kRunScript };
  Kind kind = Kind::kWaitMs;
  TargetKind target_kind = TargetKind::kEverything;  // start/stop/restart/wait status
  std::string target;                                // command name, group path or script name
  WaitFor wait = WaitFor::kNothing;
  int delay_ms = 0;  // wait ms
  SourcePos pos;
};

struct Script {
  std::string name;
  std::vector<ScriptAction> actions;
  SourcePos pos;
};

struct Config {
  std::string source;                 // file name used in messages
  std::vector<CommandSpec> commands;  // in file order
  std::vector<std::string> groups;    // every group path, in file order
  std::vector<Script> scripts;

  const CommandSpec* findCommand(std::string_view name) const;
  const Script* findScript(std::string_view name) const;
  bool hasGroup(std::string_view path) const;
  // Names of the commands in group `path` or any of its subgroups, in file order.
  std::vector<std::string> commandsInGroup(std::string_view path) const;
  // The commands a deputy called `host` runs: host equal to it, empty or "localhost".
  std::vector<CommandSpec> commandsForHost(std::string_view host) const;
};

// Parses a whole configuration. `source` names the input in error messages. Besides syntax,
// it refuses duplicate command or script names, '/' in names, values out of range, script
// actions naming an unknown command, group or script, and scripts that call themselves.
Expected<Config> parseConfig(std::string_view text, const std::string& source);
Expected<Config> loadConfig(const std::filesystem::path& file);

// Writes a configuration back in the same format (comments are not kept); parsing the result
// gives the same configuration.
std::string formatConfig(const Config& config);

// "hardware//cameras/" -> "hardware/cameras" (procman accepts both spellings).
std::string normalizeGroupPath(std::string_view path);

}  // namespace evermap::deputy
