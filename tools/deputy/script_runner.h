#pragma once
// Runs one `script` of a configuration against a Supervisor, procman style: actions one after
// the other; "start cmd X wait running" holds the script until X has started, "wait ms N"
// until N ms have passed, "run_script" runs another script to its end first. A wait has no
// time-out, as in procman.
//
// The runner never blocks: step() does what can be done now and returns; the deputy's loop
// calls it again after Supervisor::service(). Commands the configuration assigns to another
// host are not this deputy's; actions on them are skipped with a note.

#include <chrono>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "core/common/expected.h"
#include "tools/deputy/config.h"
#include "tools/deputy/supervisor.h"

namespace evermap::deputy {

class ScriptRunner {
 public:
  using Clock = std::chrono::steady_clock;
  using NoteSink = std::function<void(const std::string& text)>;

  // Error when the configuration has no script of that name.
  static Expected<ScriptRunner> create(const Config& config, const std::string& script);

  void setNoteSink(NoteSink sink) { note_ = std::move(sink); }
  // Advances as far as possible; true once the script has finished.
  bool step(Supervisor& supervisor);
  bool finished() const { return frames_.empty(); }
  // When a "wait ms" ends (Clock::time_point::max() when not in one).
  Clock::time_point nextDeadline() const;
  const std::string& name() const { return name_; }

 private:
  struct Frame {
    const Script* script = nullptr;
    size_t next = 0;
  };
  ScriptRunner(const Config& config, const Script* script);
  std::vector<std::string> targets(const ScriptAction& a, const Supervisor& supervisor) const;
  void issue(const ScriptAction& a, Supervisor& supervisor);
  bool satisfied(const ScriptAction& a, const Supervisor& supervisor) const;
  void say(const std::string& text) const {
    if (note_) note_("script \"" + name_ + "\": " + text);
  }

  const Config* config_;
  std::string name_;
  std::vector<Frame> frames_;
  bool issued_ = false;  // the current action was performed; waiting for its condition
  Clock::time_point wait_until_{};
  std::map<std::string, int> starts_at_issue_;
  NoteSink note_;
};

}  // namespace evermap::deputy
