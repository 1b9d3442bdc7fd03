#include "tools/deputy/deputy_client.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <set>

#include <evermap/deputy_proc_t.hpp>

#include "core/messages/channels.h"
#include "tools/deputy/config.h"
#include "tools/deputy/deputy_node.h"

namespace evermap::deputy {

namespace {

bool inGroup(const std::string& group, const std::string& path) {
  return group == path || (group.size() > path.size() && group.compare(0, path.size(), path) == 0 &&
                           group[path.size()] == '/');
}

std::string secondsText(double s) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g s", s);
  return buf;
}

std::chrono::steady_clock::duration seconds(double s) {
  return std::chrono::duration_cast<std::chrono::steady_clock::duration>(
      std::chrono::duration<double>(s));
}

}  // namespace

Expected<std::vector<ProcRef>> resolveTargets(const std::vector<deputy_status_t>& statuses,
                                              const std::vector<CtlTarget>& targets) {
  std::vector<ProcRef> refs;
  for (const CtlTarget& t : targets) {
    std::vector<ProcRef> found;
    const bool by_name = t.kind == CtlTarget::Kind::kAuto || t.kind == CtlTarget::Kind::kCommand;
    for (const deputy_status_t& s : statuses) {
      for (const deputy_proc_t& p : s.procs) {
        if (t.kind == CtlTarget::Kind::kEverything || (by_name && p.name == t.name)) {
          found.push_back({s.host, p.name});
        }
      }
    }
    if (found.empty() && (t.kind == CtlTarget::Kind::kAuto || t.kind == CtlTarget::Kind::kGroup)) {
      const std::string path = normalizeGroupPath(t.name);
      for (const deputy_status_t& s : statuses) {
        for (const deputy_proc_t& p : s.procs) {
          if (!path.empty() && inGroup(p.group, path)) found.push_back({s.host, p.name});
        }
      }
    }
    if (found.empty()) {
      std::set<std::string> names, groups;
      for (const deputy_status_t& s : statuses) {
        for (const deputy_proc_t& p : s.procs) {
          names.insert(p.name);
          if (!p.group.empty()) groups.insert(p.group);
        }
      }
      std::string known;
      for (const auto& n : names) known += (known.empty() ? "" : ", ") + n;
      std::string known_groups;
      for (const auto& g : groups) known_groups += (known_groups.empty() ? "" : ", ") + g;
      const char* what = t.kind == CtlTarget::Kind::kCommand ? "command"
                         : t.kind == CtlTarget::Kind::kGroup ? "group"
                                                             : "command or group";
      return makeError("no ", what, " \"", t.name,
                       "\" on any deputy (commands: ", known.empty() ? "none" : known,
                       "; groups: ", known_groups.empty() ? "none" : known_groups, ")");
    }
    for (ProcRef& r : found) {
      if (std::find(refs.begin(), refs.end(), r) == refs.end()) refs.push_back(std::move(r));
    }
  }
  return refs;
}

const char* stateText(const deputy_proc_t& p) {
  switch (p.state) {
    case deputy_proc_t::STATE_RUNNING:
      return p.desired_running ? "running" : "stopping";
    case deputy_proc_t::STATE_RESTARTING:
      return "waiting";
    case deputy_proc_t::STATE_STOPPED:
      return "stopped";
    case deputy_proc_t::STATE_FAILED:
      return "failed";
    default:
      return "unknown";
  }
}

std::string formatStatusTable(const std::vector<deputy_status_t>& statuses, bool tsv) {
  std::vector<std::vector<std::string>> rows;
  rows.push_back({"HOST", "NAME", "GROUP", "STATE", "DESIRED", "PID", "CPU%", "RSS_MB", "RESTARTS",
                  "LAST_EXIT"});
  for (const deputy_status_t& s : statuses) {
    for (const deputy_proc_t& p : s.procs) {
      char cpu[32], rss[32];
      std::snprintf(cpu, sizeof cpu, "%.1f", p.cpu_percent);
      std::snprintf(rss, sizeof rss, "%.1f", static_cast<double>(p.rss_bytes) / (1024.0 * 1024.0));
      rows.push_back({s.host, p.name, p.group.empty() ? "-" : p.group, stateText(p),
                      p.desired_running ? "run" : "stop", std::to_string(p.pid), cpu, rss,
                      std::to_string(p.restarts), std::to_string(p.last_exit_code)});
    }
  }
  std::string out;
  if (tsv) {
    for (const auto& r : rows) {
      for (size_t i = 0; i < r.size(); ++i) out += (i ? "\t" : "") + r[i];
      out += '\n';
    }
    return out;
  }
  std::vector<size_t> width(rows[0].size(), 0);
  for (const auto& r : rows) {
    for (size_t i = 0; i < r.size(); ++i) width[i] = std::max(width[i], r[i].size());
  }
  for (const auto& r : rows) {
    std::string line;
    for (size_t i = 0; i < r.size(); ++i) {
      line += r[i];
      if (i + 1 < r.size()) line += std::string(width[i] - r[i].size() + 2, ' ');
    }
    out += line + '\n';
  }
  return out;
}

Status DeputyClientOptions::validate() const {
  for (double v : {timeout_s, settle_s, resend_period_s}) {
    if (!(v > 0.0) || !std::isfinite(v))
      return makeError("deputy client: times must be > 0, got ", v);
  }
  return Ok{};
}

DeputyClient::DeputyClient(lcm::LCM& lcm, DeputyClientOptions options)
    : lcm_(lcm), out_(lcm, options.signer), options_(std::move(options)), inbox_(lcm, [this] {
        messages::Inbox::Options o;
        o.signer = options_.signer;
        o.process = "evermap-deputy-ctl";
        o.time.window_s = 0.0;
        return o;
      }()) {
  inbox_.shareChannel(channels::kDeputyStatus);  // every host's deputy
  inbox_.subscribe<deputy_status_t>(channels::kDeputyStatus,
                                    [this](const deputy_status_t& s) { onStatus(s); });
}

DeputyClient::~DeputyClient() = default;

void DeputyClient::onStatus(const deputy_status_t& s) {
  const deputy_status_t* status = &s;
  if (!options_.host.empty() && status->host != options_.host) return;
  if (status->num_procs < 0 || status->procs.size() != static_cast<size_t>(status->num_procs)) {
    return;
  }
  latest_[status->host] = *status;
  received_at_[status->host] = Clock::now();
}

void DeputyClient::pumpOnce() {
  if (pump_) {
    pump_();
  } else {
    lcm_.handleTimeout(50);
  }
}

std::vector<deputy_status_t> DeputyClient::latestList() const {
  std::vector<deputy_status_t> list;
  for (const auto& [host, s] : latest_) list.push_back(s);
  return list;
}

const deputy_proc_t* DeputyClient::find(const ProcRef& ref) const {
  const auto it = latest_.find(ref.host);
  if (it == latest_.end()) return nullptr;
  for (const deputy_proc_t& p : it->second.procs) {
    if (p.name == ref.name) return &p;
  }
  return nullptr;
}

Expected<std::vector<deputy_status_t>> DeputyClient::gather() {
  const auto start = Clock::now();
  std::optional<Clock::time_point> first;
  while (Clock::now() - start < seconds(options_.timeout_s)) {
    pumpOnce();
    if (!first && !latest_.empty()) first = Clock::now();
    // One named deputy: its status is all we need. Otherwise listen a little longer, for
    // the other deputies' 1 Hz status.
    if (first && (!options_.host.empty() || Clock::now() - *first >= seconds(options_.settle_s))) {
      return latestList();
    }
  }
  if (!latest_.empty()) return latestList();
  return makeError("no status from ", options_.host.empty() ? "any deputy" : options_.host, " on ",
                   channels::kDeputyStatus, " within ", secondsText(options_.timeout_s));
}

Status DeputyClient::order(const std::vector<ProcRef>& refs, bool running) {
  if (refs.empty()) return Ok{};
  std::map<std::string, deputy_order_t> by_host;
  for (const ProcRef& r : refs) {
    deputy_order_t& o = by_host[r.host];
    o.host = r.host;
    o.names.push_back(r.name);
    o.desired_running.push_back(running ? 1 : 0);
    o.num_procs = static_cast<int32_t>(o.names.size());
  }
  const auto first_send = Clock::now();
  auto next_send = first_send;
  while (true) {
    const auto now = Clock::now();
    bool acknowledged = true;
    for (const ProcRef& r : refs) {
      const auto at = received_at_.find(r.host);
      const deputy_proc_t* p = find(r);
      if (at == received_at_.end() || at->second <= first_send || !p ||
          (p->desired_running != 0) != running) {
        acknowledged = false;
      }
    }
    if (acknowledged) return Ok{};
    if (now - first_send > seconds(options_.timeout_s)) {
      return makeError("no acknowledgement of the ", running ? "start" : "stop", " order within ",
                       secondsText(options_.timeout_s));
    }
    if (now >= next_send) {
      for (auto& [host, o] : by_host) {
        o.utime = wallClockUtime();
        out_.publish(channels::kDeputyOrder, o);
      }
      next_send = now + seconds(options_.resend_period_s);
    }
    pumpOnce();
  }
}

Expected<std::vector<ProcRef>> DeputyClient::resolve(const std::vector<CtlTarget>& targets) {
  auto statuses = gather();
  if (!statuses) return statuses.error();
  return resolveTargets(*statuses, targets);
}

Status DeputyClient::start(const std::vector<CtlTarget>& targets) {
  auto refs = resolve(targets);
  if (!refs) return refs.error();
  std::vector<ProcRef> ended;  // should run, but has ended: re-arm with a stop first
  for (const ProcRef& r : *refs) {
    const deputy_proc_t* p = find(r);
    if (p && p->desired_running &&
        (p->state == deputy_proc_t::STATE_STOPPED || p->state == deputy_proc_t::STATE_FAILED)) {
      ended.push_back(r);
    }
  }
  if (auto s = order(ended, false); !s) return s;
  return order(*refs, true);
}

Status DeputyClient::stop(const std::vector<CtlTarget>& targets) {
  auto refs = resolve(targets);
  if (!refs) return refs.error();
  return order(*refs, false);
}

Status DeputyClient::restart(const std::vector<CtlTarget>& targets) {
  auto refs = resolve(targets);
  if (!refs) return refs.error();
  if (auto s = order(*refs, false); !s) return s;
  return order(*refs, true);
}

Status DeputyClient::waitFor(const std::vector<CtlTarget>& targets, bool running) {
  auto refs = resolve(targets);
  if (!refs) return refs.error();
  const auto start = Clock::now();
  while (true) {
    bool reached = true;
    for (const ProcRef& r : *refs) {
      const deputy_proc_t* p = find(r);
      const bool is_running = p && p->state == deputy_proc_t::STATE_RUNNING;
      const bool is_stopped = p && (p->state == deputy_proc_t::STATE_STOPPED ||
                                    p->state == deputy_proc_t::STATE_FAILED);
      if (running ? !is_running : !is_stopped) reached = false;
    }
    if (reached) return Ok{};
    if (Clock::now() - start > seconds(options_.timeout_s)) {
      return makeError("not all targets ", running ? "running" : "stopped", " within ",
                       secondsText(options_.timeout_s));
    }
    pumpOnce();
  }
}

}  // namespace evermap::deputy
