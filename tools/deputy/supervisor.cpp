#include "tools/deputy/supervisor.h"

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <set>

#include "tools/deputy/child_process.h"
#include "tools/deputy/proc_stats.h"
#include "tools/deputy/process_log.h"

namespace evermap::deputy {

struct Supervisor::Process {
  CommandSpec spec;
  LaunchPlan plan;
  ProcessState state = ProcessState::kStopped;
  bool desired = false;
  ChildHandle child;
  Clock::time_point started_at{};
  Clock::time_point stop_sent_at{};
  Clock::time_point start_at{};
  bool kill_sent = false;
  bool stop_requested = false;    // this run ends because it was asked to
  bool start_after_exit = false;  // a restart: start again once it has ended
  bool next_start_is_respawn = false;
  RespawnBackoff backoff;
  int starts = 0;
  int restarts = 0;
  bool has_ended = false;
  int last_exit_code = 0;
  double last_backoff_ms = 0.0;
  std::unique_ptr<ProcessLog> log;
  std::string partial_line;
  double cpu_percent = 0.0;
  int64_t rss_bytes = 0;
  pid_t sampled_pid = 0;
  int64_t sampled_ticks = 0;
};

const char* toString(ProcessState state) {
  switch (state) {
    case ProcessState::kStopped:
      return "stopped";
    case ProcessState::kWaiting:
      return "waiting";
    case ProcessState::kRunning:
      return "running";
    case ProcessState::kStopping:
      return "stopping";
    case ProcessState::kFailed:
      return "failed";
  }
  return "?";
}

Status SupervisorOptions::validate() const {
  if (log_dir.empty()) return makeError("supervisor: no log folder given");
  if (max_log_bytes < 0)
    return makeError("supervisor: max_log_bytes must be >= 0, got ", max_log_bytes);
  return backoff.validate();
}

namespace {

constexpr size_t kMaxLineBytes = 64 * 1024;     // a longer line without '\n' is cut here
constexpr size_t kMaxReadPerService = 1 << 20;  // so one flooding process cannot starve others
constexpr auto kPollWithoutPidfd = std::chrono::milliseconds(100);

std::string fileNameFor(const std::string& name) {
  std::string out;
  for (char c : name) {
    out +=
        (std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == '-') ? c : '_';
  }
  if (out.empty() || out[0] == '.') out.insert(out.begin(), '_');
  return out + ".log";
}

std::string describeExit(int code) {
  if (code >= 0) return "exit code " + std::to_string(code);
  const char* name = strsignal(-code);
  return "killed by signal " + std::to_string(-code) + (name ? std::string(" (") + name + ")" : "");
}

double seconds(std::chrono::steady_clock::duration d) {
  return std::chrono::duration<double>(d).count();
}

}  // namespace

Expected<std::unique_ptr<Supervisor>> Supervisor::create(std::vector<CommandSpec> commands,
                                                         SupervisorOptions options) {
  if (auto ok = options.validate(); !ok) return ok.error();
  std::set<std::string> names;
  for (const CommandSpec& c : commands) {
    if (!names.insert(c.name).second)
      return makeError("supervisor: duplicate name \"", c.name, "\"");
  }
  std::error_code ec;
  std::filesystem::create_directories(options.log_dir, ec);
  if (ec || !std::filesystem::is_directory(options.log_dir)) {
    return makeError(options.log_dir.string(), ": cannot create log folder: ", ec.message());
  }
  if (::access(options.log_dir.c_str(), W_OK) != 0) {
    return makeError(options.log_dir.string(), ": log folder is not writable");
  }
  return std::unique_ptr<Supervisor>(new Supervisor(std::move(commands), std::move(options)));
}

Supervisor::Supervisor(std::vector<CommandSpec> commands, SupervisorOptions options)
    : options_(std::move(options)) {
  for (CommandSpec& c : commands) {
    auto p = std::make_unique<Process>();
    p->plan = planLaunch(c.exec);
    p->spec = std::move(c);
    p->backoff = RespawnBackoff(options_.backoff);
    p->log = std::make_unique<ProcessLog>(logFile(p->spec.name), options_.max_log_bytes);
    processes_.push_back(std::move(p));
  }
}

Supervisor::~Supervisor() {
  for (auto& p : processes_) {
    if (p->child.pid > 0) {
      signalGroup(p->child.pid, SIGKILL);
      int status = 0;
      while (::waitpid(p->child.pid, &status, 0) < 0 && errno == EINTR) {
      }
    }
    p->child.closeFds();
  }
}

Supervisor::Process* Supervisor::find(const std::string& name) {
  for (auto& p : processes_) {
    if (p->spec.name == name) return p.get();
  }
  return nullptr;
}

const Supervisor::Process* Supervisor::find(const std::string& name) const {
  return const_cast<Supervisor*>(this)->find(name);
}

std::filesystem::path Supervisor::logFile(const std::string& name) const {
  return options_.log_dir / fileNameFor(name);
}

// ---- orders ----------------------------------------------------------------------------

Status Supervisor::start(const std::string& name) {
  Process* p = find(name);
  if (!p) return makeError("no process \"", name, "\"");
  if (shutting_down_) return makeError("\"", name, "\" not started: the deputy is shutting down");
  p->desired = true;
  switch (p->state) {
    case ProcessState::kStopping:
      p->start_after_exit = true;
      break;
    case ProcessState::kStopped:
    case ProcessState::kFailed:
      p->backoff.reset();
      scheduleStart(*p, p->spec.start_delay_ms, false);
      break;
    case ProcessState::kRunning:
    case ProcessState::kWaiting:
      break;
  }
  return Ok{};
}

Status Supervisor::stop(const std::string& name) {
  Process* p = find(name);
  if (!p) return makeError("no process \"", name, "\"");
  p->desired = false;
  p->start_after_exit = false;
  if (p->state == ProcessState::kRunning) requestStop(*p);
  if (p->state == ProcessState::kWaiting) {
    p->state = ProcessState::kStopped;
    note(*p, "start cancelled");
  }
  return Ok{};
}

Status Supervisor::restart(const std::string& name) {
  Process* p = find(name);
  if (!p) return makeError("no process \"", name, "\"");
  if (shutting_down_) return makeError("\"", name, "\" not restarted: the deputy is shutting down");
  p->desired = true;
  p->backoff.reset();
  switch (p->state) {
    case ProcessState::kRunning:
      requestStop(*p);
      p->start_after_exit = true;
      break;
    case ProcessState::kStopping:
      p->start_after_exit = true;
      break;
    case ProcessState::kWaiting:
    case ProcessState::kStopped:
    case ProcessState::kFailed:
      scheduleStart(*p, p->spec.start_delay_ms, false);
      break;
  }
  return Ok{};
}

Status Supervisor::setDesired(const std::string& name, bool running) {
  const Process* p = find(name);
  if (!p) return makeError("no process \"", name, "\"");
  if (p->desired == running) return Ok{};
  return running ? start(name) : stop(name);
}

void Supervisor::beginShutdown() {
  shutting_down_ = true;
  for (auto& p : processes_) (void)stop(p->spec.name);
}

void Supervisor::killAll() {
  for (auto& p : processes_) {
    if (p->child.pid > 0) {
      signalGroup(p->child.pid, SIGKILL);
      p->kill_sent = true;
      p->stop_requested = true;
    }
  }
}

bool Supervisor::allStopped() const {
  for (const auto& p : processes_) {
    if (p->state != ProcessState::kStopped && p->state != ProcessState::kFailed) return false;
  }
  return true;
}

// ---- life cycle ------------------------------------------------------------------------

void Supervisor::scheduleStart(Process& p, double delay_ms, bool respawn) {
  p.state = ProcessState::kWaiting;
  p.next_start_is_respawn = respawn;
  p.start_at = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                  std::chrono::duration<double, std::milli>(delay_ms));
}

void Supervisor::launch(Process& p) {
  const bool respawn = p.next_start_is_respawn;
  p.next_start_is_respawn = false;
  p.stop_requested = false;
  p.kill_sent = false;
  p.partial_line.clear();
  ++p.starts;
  if (respawn) ++p.restarts;
  auto child = spawnChild(p.plan);
  if (!child) {
    // Counts as a run that ended at once with the shell's "cannot execute" status.
    note(p, child.error().message);
    p.started_at = Clock::now();
    onEnded(p, 127);
    return;
  }
  p.child = *child;
  p.started_at = Clock::now();
  p.state = ProcessState::kRunning;
  p.sampled_pid = 0;
  note(p, std::string(respawn ? "restarted" : "started") + " pid " + std::to_string(p.child.pid) +
              (p.plan.via_shell ? " (via /bin/sh -c): " : ": ") + p.spec.exec);
}

void Supervisor::requestStop(Process& p) {
  p.stop_requested = true;
  p.state = ProcessState::kStopping;
  p.stop_sent_at = Clock::now();
  p.kill_sent = false;
  const char* name = strsignal(p.spec.stop_signal);
  note(p, "stopping: signal " + std::to_string(p.spec.stop_signal) +
              (name ? std::string(" (") + name + ")" : "") + ", SIGKILL after " +
              std::to_string(p.spec.stop_time_allowed_s) + " s");
  signalGroup(p.child.pid, p.spec.stop_signal);
}

void Supervisor::reap(Process& p) {
  if (p.child.pid <= 0) return;
  // Look without reaping first: while the leader is a zombie its pid, and so the group id,
  // cannot be reused, so killing what is left of its group cannot hit a stranger.
  siginfo_t info{};
  if (::waitid(P_PID, static_cast<id_t>(p.child.pid), &info, WEXITED | WNOHANG | WNOWAIT) != 0 ||
      info.si_pid != p.child.pid) {
    return;
  }
  signalGroup(p.child.pid, SIGKILL);
  int status = 0;
  while (::waitpid(p.child.pid, &status, 0) < 0 && errno == EINTR) {
  }
  const int code = WIFEXITED(status)     ? WEXITSTATUS(status)
                   : WIFSIGNALED(status) ? -WTERMSIG(status)
                                         : -1;
  onEnded(p, code);
}

void Supervisor::onEnded(Process& p, int exit_code) {
  const double ran_s = seconds(Clock::now() - p.started_at);
  // Output still in the pipe; members of the group that held it open were killed in reap().
  if (p.child.pid > 0) readOutput(p, true);
  flushPartialLine(p);
  p.child.closeFds();
  p.child.pid = 0;
  p.has_ended = true;
  p.last_exit_code = exit_code;
  p.cpu_percent = 0.0;
  p.rss_bytes = 0;
  char ran[32];
  std::snprintf(ran, sizeof ran, "%.3f", ran_s);
  note(p, "ended: " + describeExit(exit_code) + " after " + ran + " s");

  if (shutting_down_) {
    p.state = ProcessState::kStopped;
  } else if (p.start_after_exit) {
    p.start_after_exit = false;
    scheduleStart(p, p.spec.start_delay_ms, false);
  } else if (p.stop_requested) {
    p.state = ProcessState::kStopped;
  } else if (p.desired && p.spec.auto_respawn) {
    p.last_backoff_ms = p.backoff.onExit(ran_s);
    char wait[48];
    std::snprintf(wait, sizeof wait, "%.0f ms", p.last_backoff_ms);
    note(p, std::string("auto_respawn: restarting in ") + wait);
    scheduleStart(p, p.last_backoff_ms, true);
  } else {
    p.state = exit_code == 0 ? ProcessState::kStopped : ProcessState::kFailed;
  }
}

void Supervisor::service() {
  const auto now = Clock::now();
  for (auto& pp : processes_) {
    Process& p = *pp;
    if (p.child.output_fd >= 0) readOutput(p, false);
    if (p.state == ProcessState::kRunning || p.state == ProcessState::kStopping) reap(p);
    if (p.state == ProcessState::kStopping && !p.kill_sent &&
        now >= p.stop_sent_at + std::chrono::seconds(p.spec.stop_time_allowed_s)) {
      note(p, "still running " + std::to_string(p.spec.stop_time_allowed_s) +
                  " s after the stop signal: SIGKILL");
      signalGroup(p.child.pid, SIGKILL);
      p.kill_sent = true;
    }
    if (p.state == ProcessState::kWaiting && now >= p.start_at) launch(p);
  }
}

void Supervisor::appendPollFds(std::vector<pollfd>* fds) const {
  for (const auto& p : processes_) {
    if (p->child.output_fd >= 0) fds->push_back({p->child.output_fd, POLLIN, 0});
    if (p->child.pid_fd >= 0) fds->push_back({p->child.pid_fd, POLLIN, 0});
  }
}

Supervisor::Clock::time_point Supervisor::nextDeadline() const {
  auto t = Clock::time_point::max();
  const auto now = Clock::now();
  for (const auto& p : processes_) {
    if (p->state == ProcessState::kWaiting) t = std::min(t, p->start_at);
    if (p->state == ProcessState::kStopping && !p->kill_sent) {
      t = std::min(t, p->stop_sent_at + std::chrono::seconds(p->spec.stop_time_allowed_s));
    }
    // Without a pidfd, an ending child is noticed by polling waitpid.
    if (p->child.pid > 0 && p->child.pid_fd < 0) t = std::min(t, now + kPollWithoutPidfd);
  }
  return t;
}

// ---- output ----------------------------------------------------------------------------

void Supervisor::readOutput(Process& p, bool until_eof) {
  char buf[16384];
  size_t total = 0;
  while (p.child.output_fd >= 0 && (until_eof || total < kMaxReadPerService)) {
    const ssize_t n = ::read(p.child.output_fd, buf, sizeof buf);
    if (n > 0) {
      total += static_cast<size_t>(n);
      emitLines(p, std::string_view(buf, static_cast<size_t>(n)));
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    if (n == 0) {
      // Every writer closed the pipe: stop polling it (the process may still run).
      ::close(p.child.output_fd);
      p.child.output_fd = -1;
    }
    return;  // EAGAIN: nothing more for now (members of the group may still hold the pipe)
  }
}

void Supervisor::emitLines(Process& p, std::string_view chunk) {
  std::string complete;  // written to the log in one call
  for (char c : chunk) {
    if (c == '\n' || p.partial_line.size() >= kMaxLineBytes) {
      complete += p.partial_line;
      complete += '\n';
      if (sink_) sink_(p.spec.name, p.partial_line, false);
      p.partial_line.clear();
      if (c == '\n') continue;
    }
    p.partial_line += c;
  }
  if (!complete.empty()) p.log->write(complete);
}

void Supervisor::flushPartialLine(Process& p) {
  if (p.partial_line.empty()) return;
  emitLines(p, "\n");
}

void Supervisor::note(Process& p, const std::string& text) {
  p.log->note(text);
  if (sink_) sink_(p.spec.name, text, true);
}

// ---- measurements ----------------------------------------------------------------------

void Supervisor::sampleUsage() {
  const auto now = Clock::now();
  const double dt = last_sample_ == Clock::time_point{} ? 0.0 : seconds(now - last_sample_);
  last_sample_ = now;
  std::set<pid_t> groups;
  for (const auto& p : processes_) {
    if (p->child.pid > 0) groups.insert(p->child.pid);
  }
  const auto usage = sampleGroups(groups);
  const double tck = ticksPerSecond();
  for (auto& p : processes_) {
    const auto it = p->child.pid > 0 ? usage.find(p->child.pid) : usage.end();
    if (it == usage.end()) {
      p->cpu_percent = 0.0;
      p->rss_bytes = 0;
      continue;
    }
    p->rss_bytes = it->second.rss_bytes;
    if (p->sampled_pid == p->child.pid && dt > 0.0) {
      // Members that end and are reaped outside the group take their ticks along: clamp.
      const int64_t delta = std::max<int64_t>(0, it->second.cpu_ticks - p->sampled_ticks);
      p->cpu_percent = 100.0 * static_cast<double>(delta) / tck / dt;
    }
    p->sampled_pid = p->child.pid;
    p->sampled_ticks = it->second.cpu_ticks;
  }
}

std::vector<ProcessStatus> Supervisor::status() const {
  std::vector<ProcessStatus> out;
  for (const auto& p : processes_) out.push_back(*status(p->spec.name));
  return out;
}

std::optional<ProcessStatus> Supervisor::status(const std::string& name) const {
  const Process* p = find(name);
  if (!p) return std::nullopt;
  ProcessStatus s;
  s.name = p->spec.name;
  s.group = p->spec.group;
  s.command = p->spec.exec;
  s.state = p->state;
  s.desired_running = p->desired;
  s.pid = p->child.pid;
  s.starts = p->starts;
  s.restarts = p->restarts;
  s.has_ended = p->has_ended;
  s.last_exit_code = p->last_exit_code;
  s.cpu_percent = p->cpu_percent;
  s.rss_bytes = p->rss_bytes;
  s.last_backoff_ms = p->last_backoff_ms;
  return s;
}

}  // namespace evermap::deputy
