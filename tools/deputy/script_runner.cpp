#include "tools/deputy/script_runner.h"

namespace evermap::deputy {

Expected<ScriptRunner> ScriptRunner::create(const Config& config, const std::string& script) {
  const Script* s = config.findScript(script);
  if (!s) {
    std::string known;
    for (const Script& k : config.scripts) known += (known.empty() ? "" : ", ") + k.name;
    return makeError(config.source, ": no script \"", script,
                     "\" (scripts: ", known.empty() ? "none" : known, ")");
  }
  return ScriptRunner(config, s);
}

ScriptRunner::ScriptRunner(const Config& config, const Script* script)
    : config_(&config), name_(script->name) {
  frames_.push_back({script, 0});
}

std::vector<std::string> ScriptRunner::targets(const ScriptAction& a,
                                               const Supervisor& supervisor) const {
  std::vector<std::string> all;
  switch (a.target_kind) {
    case TargetKind::kEverything:
      for (const CommandSpec& c : config_->commands) all.push_back(c.name);
      break;
    case TargetKind::kCommand:
      all.push_back(a.target);
      break;
    case TargetKind::kGroup:
      all = config_->commandsInGroup(a.target);
      break;
  }
  std::vector<std::string> mine;
  for (std::string& n : all) {
    if (supervisor.has(n)) mine.push_back(std::move(n));
  }
  return mine;
}

void ScriptRunner::issue(const ScriptAction& a, Supervisor& supervisor) {
  using Kind = ScriptAction::Kind;
  if (a.kind == Kind::kWaitMs) {
    wait_until_ = Clock::now() + std::chrono::milliseconds(a.delay_ms);
    return;
  }
  const auto names = targets(a, supervisor);
  if (names.empty() && a.kind != Kind::kRunScript) {
    say("line " + std::to_string(a.pos.line) + ": \"" + a.target +
        "\" has no command on this deputy, skipped");
  }
  starts_at_issue_.clear();
  for (const std::string& n : names) starts_at_issue_[n] = supervisor.status(n)->starts;
  for (const std::string& n : names) {
    Status s = Ok{};
    if (a.kind == Kind::kStart) s = supervisor.start(n);
    if (a.kind == Kind::kStop) s = supervisor.stop(n);
    if (a.kind == Kind::kRestart) s = supervisor.restart(n);
    if (!s) say(s.error().message);
  }
}

bool ScriptRunner::satisfied(const ScriptAction& a, const Supervisor& supervisor) const {
  if (a.kind == ScriptAction::Kind::kWaitMs) return Clock::now() >= wait_until_;
  if (a.wait == WaitFor::kNothing) return true;
  for (const std::string& n : targets(a, supervisor)) {
    const ProcessStatus s = *supervisor.status(n);
    if (a.wait == WaitFor::kRunning) {
      // A short-lived command may start and end between two looks: having started counts.
      const auto it = starts_at_issue_.find(n);
      const bool started_since = it != starts_at_issue_.end() && s.starts > it->second;
      if (s.state != ProcessState::kRunning && !started_since) return false;
    } else if (s.state != ProcessState::kStopped && s.state != ProcessState::kFailed) {
      return false;
    }
  }
  return true;
}

bool ScriptRunner::step(Supervisor& supervisor) {
  while (!frames_.empty()) {
    Frame& f = frames_.back();
    if (f.next >= f.script->actions.size()) {
      frames_.pop_back();
      continue;
    }
    const ScriptAction& a = f.script->actions[f.next];
    if (a.kind == ScriptAction::Kind::kRunScript) {
      ++f.next;
      say("running script \"" + a.target + "\"");
      frames_.push_back({config_->findScript(a.target), 0});  // checked by parseConfig
      continue;
    }
    if (!issued_) {
      issue(a, supervisor);
      issued_ = true;
    }
    if (!satisfied(a, supervisor)) return false;
    issued_ = false;
    ++f.next;
  }
  return true;
}

ScriptRunner::Clock::time_point ScriptRunner::nextDeadline() const {
  if (frames_.empty() || !issued_) return Clock::time_point::max();
  const Frame& f = frames_.back();
  if (f.next < f.script->actions.size() &&
      f.script->actions[f.next].kind == ScriptAction::Kind::kWaitMs) {
    return wait_until_;
  }
  return Clock::time_point::max();
}

}  // namespace evermap::deputy
