// Look-ups on a parsed configuration, and writing one back in procman's format.
#include <map>
#include <sstream>

#include "core/common/quoted_text.h"
#include "tools/deputy/config.h"

namespace evermap::deputy {

const CommandSpec* Config::findCommand(std::string_view name) const {
  for (const CommandSpec& c : commands) {
    if (c.name == name) return &c;
  }
  return nullptr;
}

const Script* Config::findScript(std::string_view name) const {
  for (const Script& s : scripts) {
    if (s.name == name) return &s;
  }
  return nullptr;
}

bool Config::hasGroup(std::string_view path) const {
  const std::string p = normalizeGroupPath(path);
  for (const std::string& g : groups) {
    if (g == p) return true;
  }
  return false;
}

namespace {
bool inGroup(const std::string& command_group, const std::string& path) {
  return command_group == path ||
         (command_group.size() > path.size() && command_group.compare(0, path.size(), path) == 0 &&
          command_group[path.size()] == '/');
}
}  // namespace

std::vector<std::string> Config::commandsInGroup(std::string_view path) const {
  const std::string p = normalizeGroupPath(path);
  std::vector<std::string> names;
  for (const CommandSpec& c : commands) {
    if (inGroup(c.group, p)) names.push_back(c.name);
  }
  return names;
}

std::vector<CommandSpec> Config::commandsForHost(std::string_view host) const {
  std::vector<CommandSpec> mine;
  for (const CommandSpec& c : commands) {
    if (c.host.empty() || c.host == "localhost" || c.host == host) mine.push_back(c);
  }
  return mine;
}

std::string normalizeGroupPath(std::string_view path) {
  std::string out;
  size_t i = 0;
  while (i < path.size()) {
    while (i < path.size() && path[i] == '/') ++i;
    const size_t start = i;
    while (i < path.size() && path[i] != '/') ++i;
    if (i > start) {
      if (!out.empty()) out += '/';
      out.append(path.substr(start, i - start));
    }
  }
  return out;
}

namespace {

std::string quote(const std::string& s) { return quotedText(s, /*escape_controls=*/false); }

void writeCommand(std::ostringstream& out, const CommandSpec& c, const std::string& indent) {
  out << indent << "cmd " << quote(c.name) << " {\n";
  out << indent << "    exec = " << quote(c.exec) << ";\n";
  if (!c.host.empty()) out << indent << "    host = " << quote(c.host) << ";\n";
  if (c.auto_respawn) out << indent << "    auto_respawn = \"true\";\n";
  if (c.stop_signal != CommandSpec{}.stop_signal) {
    out << indent << "    stop_signal = " << c.stop_signal << ";\n";
  }
  if (c.stop_time_allowed_s != CommandSpec{}.stop_time_allowed_s) {
    out << indent << "    stop_time_allowed = " << c.stop_time_allowed_s << ";\n";
  }
  if (c.start_delay_ms != 0) out << indent << "    start_delay_ms = " << c.start_delay_ms << ";\n";
  out << indent << "}\n";
}

// Writes the group `path` ("" for the top level): its own commands, then its subgroups.
void writeGroup(std::ostringstream& out, const Config& config, const std::string& path, int depth) {
  const std::string indent(4 * depth, ' ');
  for (const CommandSpec& c : config.commands) {
    if (c.group == path) writeCommand(out, c, indent);
  }
  for (const std::string& g : config.groups) {
    const size_t slash = g.rfind('/');
    const std::string parent = slash == std::string::npos ? "" : g.substr(0, slash);
    if (parent != path) continue;
    out << indent << "group " << quote(g.substr(slash == std::string::npos ? 0 : slash + 1))
        << " {\n";
    writeGroup(out, config, g, depth + 1);
    out << indent << "}\n";
  }
}

std::string targetText(const ScriptAction& a) {
  switch (a.target_kind) {
    case TargetKind::kEverything:
      return "everything";
    case TargetKind::kCommand:
      return "cmd " + quote(a.target);
    case TargetKind::kGroup:
      return "group " + quote(a.target);
  }
  return "";
}

const char* statusText(WaitFor w) { return w == WaitFor::kRunning ? "\"running\"" : "\"stopped\""; }

}  // namespace

std::string formatConfig(const Config& config) {
  std::ostringstream out;
  writeGroup(out, config, "", 0);
  for (const Script& s : config.scripts) {
    out << "script " << quote(s.name) << " {\n";
    for (const ScriptAction& a : s.actions) {
      out << "    ";
      switch (a.kind) {
        case ScriptAction::Kind::kStart:
        case ScriptAction::Kind::kStop:
        case ScriptAction::Kind::kRestart:
          out << (a.kind == ScriptAction::Kind::kStart  ? "start "
                  : a.kind == ScriptAction::Kind::kStop ? "stop "
                                                        : "restart ")
              << targetText(a);
          if (a.wait != WaitFor::kNothing) out << " wait " << statusText(a.wait);
          break;
        case ScriptAction::Kind::kWaitMs:
          out << "wait ms " << a.delay_ms;
          break;
        case ScriptAction::Kind::kWaitStatus:
          out << "wait " << targetText(a) << " status " << statusText(a.wait);
          break;
        case ScriptAction::Kind::kRunScript:
          out << "run_script " << quote(a.target);
          break;
      }
      out << ";\n";
    }
    out << "}\n";
  }
  return out.str();
}

}  // namespace evermap::deputy
