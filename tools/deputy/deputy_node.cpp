#include "tools/deputy/deputy_node.h"

#include <poll.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <evermap/deputy_output_t.hpp>
#include <evermap/deputy_proc_t.hpp>

#include "core/messages/channels.h"

namespace evermap::deputy {

Status DeputyNodeOptions::validate() const {
  if (host.empty()) return makeError("deputy: empty host name");
  if (!(status_period_s > 0.0) || !std::isfinite(status_period_s)) {
    return makeError("deputy: status_period_s must be finite and > 0, got ", status_period_s);
  }
  if (!(min_status_gap_s >= 0.0) || !std::isfinite(min_status_gap_s)) {
    return makeError("deputy: min_status_gap_s must be finite and >= 0, got ", min_status_gap_s);
  }
  return output.validate();
}

int8_t messageState(ProcessState state) {
  switch (state) {
    case ProcessState::kStopped:
      return deputy_proc_t::STATE_STOPPED;
    case ProcessState::kRunning:
    case ProcessState::kStopping:
      return deputy_proc_t::STATE_RUNNING;  // pid != 0, desired 0
    case ProcessState::kWaiting:
      return deputy_proc_t::STATE_RESTARTING;
    case ProcessState::kFailed:
      return deputy_proc_t::STATE_FAILED;
  }
  return deputy_proc_t::STATE_FAILED;
}

int64_t wallClockUtime() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

namespace {
Supervisor::Clock::duration secondsToDuration(double s) {
  return std::chrono::duration_cast<Supervisor::Clock::duration>(std::chrono::duration<double>(s));
}
}  // namespace

DeputyNode::DeputyNode(lcm::LCM& lcm, Supervisor& supervisor, DeputyNodeOptions options)
    : lcm_(lcm),
      out_(lcm, options.signer),
      supervisor_(supervisor),
      options_(std::move(options)),
      throttle_(options_.output),
      inbox_(lcm, [this] {
        messages::Inbox::Options o;
        o.process = "evermap-deputy";
        o.time.window_s = 0.0;
        o.signer = options_.signer;
        return o;
      }()) {
  inbox_.shareChannel(channels::kDeputyOrder);  // any client may give orders
  inbox_.subscribe<deputy_order_t>(channels::kDeputyOrder,
                                   [this](const deputy_order_t& o) { return onOrder(o); });
  supervisor_.setLineSink([this](const std::string& name, const std::string& line,
                                 bool from_deputy) { onLine(name, line, from_deputy); });
  next_status_ = Clock::now();  // the first status goes out at once
}

DeputyNode::~DeputyNode() { supervisor_.setLineSink(nullptr); }

void DeputyNode::runScript(ScriptRunner runner) {
  script_.emplace(std::move(runner));
  script_->setNoteSink([this](const std::string& text) {
    if (options_.print_notes) std::fprintf(stderr, "evermap-deputy: %s\n", text.c_str());
  });
}

Status DeputyNode::onOrder(const deputy_order_t& o) {
  const deputy_order_t* order = &o;
  if (!order->host.empty() && order->host != options_.host) {
    ++counters_.orders_for_others;
    return Ok{};
  }
  const size_t n = static_cast<size_t>(std::max(0, order->num_procs));
  if (order->num_procs < 0 || order->names.size() != n || order->desired_running.size() != n) {
    ++counters_.orders_malformed;
    return makeError("order of ", order->num_procs, " processes with ", order->names.size(),
                     " names and ", order->desired_running.size(), " states");
  }
  for (const int8_t d : order->desired_running) {
    if (d != 0 && d != 1) {
      ++counters_.orders_malformed;
      return makeError("desired_running ", static_cast<int>(d), " is neither 0 nor 1");
    }
  }
  ++counters_.orders_applied;
  for (size_t i = 0; i < n; ++i) {
    const std::string& name = order->names[i];
    if (!supervisor_.has(name)) {
      ++counters_.unknown_names;
      continue;
    }
    const Status s = supervisor_.setDesired(name, order->desired_running[i] != 0);
    if (!s && options_.print_notes) {
      std::fprintf(stderr, "evermap-deputy: order: %s\n", s.error().message.c_str());
    }
  }
  return Ok{};
}

DeputyNode::Counters DeputyNode::counters() const {
  Counters c = counters_;
  const messages::ChannelCounts in = inbox_.total();
  c.orders_malformed += in.malformed;  // the content refusals are counted by onOrder already
  c.handler_failed = in.failed;
  return c;
}

void DeputyNode::onLine(const std::string& name, const std::string& line, bool from_deputy) {
  if (from_deputy && options_.print_notes) {
    std::fprintf(stderr, "evermap-deputy: [%s] %s\n", name.c_str(), line.c_str());
  }
  if (options_.publish_output) {
    throttle_.addLine(name, from_deputy ? "[deputy] " + line : line, Clock::now());
  }
}

std::string DeputyNode::stateSignature() const {
  std::string sig;
  for (const ProcessStatus& s : supervisor_.status()) {
    sig += std::to_string(static_cast<int>(s.state)) + ":" + std::to_string(s.pid) + ":" +
           (s.desired_running ? "1" : "0") + ";";
  }
  return sig;
}

deputy_status_t DeputyNode::makeStatus() const {
  deputy_status_t msg;
  msg.utime = wallClockUtime();
  msg.host = options_.host;
  for (const ProcessStatus& s : supervisor_.status()) {
    deputy_proc_t p;
    p.name = s.name;
    p.group = s.group;
    p.command = s.command;
    p.pid = s.pid;
    p.state = messageState(s.state);
    p.desired_running = s.desired_running ? 1 : 0;
    p.restarts = s.restarts;
    p.last_exit_code = s.last_exit_code;
    p.cpu_percent = s.cpu_percent;
    p.rss_bytes = s.rss_bytes;
    msg.procs.push_back(std::move(p));
  }
  msg.num_procs = static_cast<int32_t>(msg.procs.size());
  return msg;
}

void DeputyNode::publishStatus() {
  flushOutput();
  const deputy_status_t msg = makeStatus();
  out_.publish(channels::kDeputyStatus, msg);
  ++counters_.status_published;
  last_status_ = Clock::now();
  last_signature_ = stateSignature();
}

void DeputyNode::flushOutput() { publishOutput(true); }

void DeputyNode::publishOutput(bool all) {
  for (const auto& batch : throttle_.takeDue(Clock::now(), all)) {
    deputy_output_t out;
    out.utime = wallClockUtime();
    out.host = options_.host;
    out.name = batch.name;
    out.text = batch.text;
    out_.publish(channels::kDeputyOutput, out);
    ++counters_.output_published;
  }
}

void DeputyNode::spinOnce(int max_wait_ms, int extra_fd) {
  std::vector<pollfd> fds;
  const int lcm_fd = lcm_.getFileno();
  if (lcm_fd >= 0) fds.push_back({lcm_fd, POLLIN, 0});
  if (extra_fd >= 0) fds.push_back({extra_fd, POLLIN, 0});
  supervisor_.appendPollFds(&fds);

  auto now = Clock::now();
  auto deadline = now + std::chrono::milliseconds(std::max(0, max_wait_ms));
  deadline = std::min({deadline, supervisor_.nextDeadline(), next_status_, throttle_.nextDue()});
  if (script_) deadline = std::min(deadline, script_->nextDeadline());
  if (change_pending_) {
    deadline = std::min(deadline, last_status_ + secondsToDuration(options_.min_status_gap_s));
  }
  const auto wait_ms = std::chrono::ceil<std::chrono::milliseconds>(deadline - now).count();
  ::poll(fds.data(), fds.size(), static_cast<int>(std::clamp<int64_t>(wait_ms, 0, max_wait_ms)));

  if (lcm_fd >= 0 && (fds[0].revents & POLLIN)) {
    // Bounded, so a flood of messages cannot starve the supervision.
    for (int i = 0; i < 100 && lcm_.handleTimeout(0) > 0; ++i) {
    }
  }
  supervisor_.service();
  if (script_ && script_->step(supervisor_)) {
    if (options_.print_notes) {
      std::fprintf(stderr, "evermap-deputy: script \"%s\" finished\n", script_->name().c_str());
    }
    script_.reset();
  }

  now = Clock::now();
  change_pending_ = false;
  if (now >= next_status_) {
    supervisor_.sampleUsage();
    publishStatus();
    next_status_ = now + secondsToDuration(options_.status_period_s);
  } else if (stateSignature() != last_signature_) {
    if (now - last_status_ >= secondsToDuration(options_.min_status_gap_s)) {
      publishStatus();
    } else {
      change_pending_ = true;
    }
  }
  publishOutput(false);
}

}  // namespace evermap::deputy
