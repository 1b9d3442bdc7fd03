#pragma once
// The process table of a deputy: starts, watches, stops and restarts the commands of a
// configuration, and keeps each one's output in its own log file. Knows nothing of LCM
// (DeputyNode publishes what it reports and passes on the orders it receives).
//
// States of one process:
//   kStopped --start--> kWaiting (start_delay_ms) --> kRunning --ends--> kWaiting (back-off)
//                                                        |                 if auto_respawn
//                                                      stop              else kStopped
//                                                        v                 (exit 0) / kFailed
//                                    kStopping (stop_signal; SIGKILL after stop_time_allowed)
// A process that ends while it should run is restarted only with auto_respawn, after the
// RespawnBackoff wait. When the group leader ends, members of its process group that are still
// alive are killed, so no copy of the program survives into the next run.
//
// Threading: one thread calls everything (the deputy's loop). Time is the wall clock (this is
// supervision of real processes).

#include <poll.h>
#include <sys/types.h>

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/common/expected.h"
#include "tools/deputy/backoff.h"
#include "tools/deputy/config.h"

namespace evermap::deputy {

enum class ProcessState { kStopped, kWaiting, kRunning, kStopping, kFailed };
const char* toString(ProcessState state);

struct ProcessStatus {
  std::string name;
  std::string group;
  std::string command;
  ProcessState state = ProcessState::kStopped;
  bool desired_running = false;
  pid_t pid = 0;               // 0 when not running
  int starts = 0;              // every start, ordered or automatic
  int restarts = 0;            // automatic restarts after the process ended
  bool has_ended = false;      // it ran and ended at least once
  int last_exit_code = 0;      // exit status, or -N when ended by signal N
  double cpu_percent = 0.0;    // of one core, over the last sampleUsage() period
  int64_t rss_bytes = 0;       // resident memory of its process group
  double last_backoff_ms = 0;  // the wait before the latest automatic restart
};

struct SupervisorOptions {
  // One "<name>.log" per process (characters other than [A-Za-z0-9._-] become '_'), appended
  // to; created if missing.
  std::filesystem::path log_dir;
  // A log file that reaches this size, bytes, is renamed to "<name>.log.1" (replacing the
  // previous one) and started afresh; 0 keeps one file without limit.
  int64_t max_log_bytes = int64_t{256} << 20;
  BackoffOptions backoff;

  Status validate() const;
};

class Supervisor {
 public:
  using Clock = std::chrono::steady_clock;
  // Receives each output line (without '\n') of process `name`; `from_deputy` marks the
  // deputy's own notes about it ("started pid 12", "ended: exit code 3").
  using LineSink =
      std::function<void(const std::string& name, const std::string& line, bool from_deputy)>;

  // Errors: invalid options, a log folder that cannot be created, duplicate names.
  static Expected<std::unique_ptr<Supervisor>> create(std::vector<CommandSpec> commands,
                                                      SupervisorOptions options);
  // Kills (SIGKILL) and reaps whatever still runs, so no child outlives its supervisor.
  ~Supervisor();
  Supervisor(const Supervisor&) = delete;
  Supervisor& operator=(const Supervisor&) = delete;

  void setLineSink(LineSink sink) { sink_ = std::move(sink); }

  // Orders. An unknown name is an error naming it.
  Status start(const std::string& name);    // run it (again, if it ended)
  Status stop(const std::string& name);     // stop it; no automatic restart
  Status restart(const std::string& name);  // stop if running, then start
  // A desired state from the network, procman style: acts only when it differs from the
  // current desired state, so the same order received again changes nothing.
  Status setDesired(const std::string& name, bool running);

  // Stops everything (stop_signal, SIGKILL after stop_time_allowed) and refuses new starts.
  void beginShutdown();
  // SIGKILL to every process group now (a second interrupt).
  void killAll();
  bool shuttingDown() const { return shutting_down_; }
  // Nothing running, stopping or waiting to start.
  bool allStopped() const;

  // Reads output, reaps ended children, fires start and SIGKILL deadlines. Call after poll()
  // returns, and at nextDeadline() at the latest.
  void service();
  // Measures CPU and memory of every running process (cpu over the time since the last call).
  void sampleUsage();
  // Descriptors that become readable when something happens (output, a child ending).
  void appendPollFds(std::vector<pollfd>* fds) const;
  Clock::time_point nextDeadline() const;

  bool has(const std::string& name) const { return find(name) != nullptr; }
  std::vector<ProcessStatus> status() const;
  std::optional<ProcessStatus> status(const std::string& name) const;
  std::filesystem::path logFile(const std::string& name) const;

 private:
  struct Process;
  Supervisor(std::vector<CommandSpec> commands, SupervisorOptions options);
  Process* find(const std::string& name);
  const Process* find(const std::string& name) const;
  void scheduleStart(Process& p, double delay_ms, bool respawn);
  void launch(Process& p);
  void requestStop(Process& p);
  void reap(Process& p);
  void onEnded(Process& p, int exit_code);
  void readOutput(Process& p, bool until_eof);
  void emitLines(Process& p, std::string_view chunk);
  void flushPartialLine(Process& p);
  void note(Process& p, const std::string& text);

  SupervisorOptions options_;
  std::vector<std::unique_ptr<Process>> processes_;
  LineSink sink_;
  bool shutting_down_ = false;
  Clock::time_point last_sample_{};
};

}  // namespace evermap::deputy
