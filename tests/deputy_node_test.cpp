// The deputy on LCM, in one process over memq://: status, orders, output, the control
// client's start/stop/restart, and scripts.
#include <gtest/gtest.h>

#include <random>

#include <lcm/lcm-cpp.hpp>

#include <evermap/deputy_output_t.hpp>
#include <evermap/deputy_proc_t.hpp>

#include "core/messages/channels.h"
#include "deputy_test_util.h"
#include "scratch_dir.h"
#include "tools/deputy/deputy_client.h"
#include "tools/deputy/deputy_node.h"

namespace evermap::deputy {
namespace {

using testing::command;
using testing::respawning;
using Clock = std::chrono::steady_clock;
// Copies: the generated constants have no out-of-line definition, and EXPECT_EQ takes them by
// reference.
constexpr int kStopped = deputy_proc_t::STATE_STOPPED;
constexpr int kRunning = deputy_proc_t::STATE_RUNNING;

// Everything a test listens to, on the same memq LCM as the deputy.
struct Listener {
  std::vector<deputy_status_t> statuses;
  std::vector<deputy_output_t> outputs;
  void onStatus(const lcm::ReceiveBuffer*, const std::string&, const deputy_status_t* s) {
    statuses.push_back(*s);
  }
  void onOutput(const lcm::ReceiveBuffer*, const std::string&, const deputy_output_t* o) {
    outputs.push_back(*o);
  }
  const deputy_proc_t* latest(const std::string& name) const {
    if (statuses.empty()) return nullptr;
    for (const auto& p : statuses.back().procs) {
      if (p.name == name) return &p;
    }
    return nullptr;
  }
  std::string allOutput(const std::string& name) const {
    std::string all;
    for (const auto& o : outputs) {
      if (o.name == name) all += o.text;
    }
    return all;
  }
};

class DeputyNodeTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(lcm_.good());
    lcm_.subscribe(channels::kDeputyStatus, &Listener::onStatus, &listener_);
    lcm_.subscribe(channels::kDeputyOutput, &Listener::onOutput, &listener_);
  }

  void makeDeputy(std::vector<CommandSpec> commands) {
    SupervisorOptions o;
    o.log_dir = dir_ / "logs";
    auto s = Supervisor::create(std::move(commands), o);
    ASSERT_TRUE(s.ok()) << s.error().message;
    supervisor_ = std::move(*s);
    DeputyNodeOptions n;
    n.host = "robot";
    ASSERT_TRUE(n.validate().ok());
    node_ = std::make_unique<DeputyNode>(lcm_, *supervisor_, n);
  }

  bool spinUntil(const std::function<bool()>& done) {
    const auto end = Clock::now() + std::chrono::duration<double>(testing::kGenerousTimeoutS);
    while (Clock::now() < end) {
      node_->spinOnce(20);
      if (done()) return true;
    }
    return false;
  }

  void order(const std::string& host, const std::string& name, bool run) {
    deputy_order_t o;
    o.utime = wallClockUtime();
    o.host = host;
    o.num_procs = 1;
    o.names = {name};
    o.desired_running = {static_cast<int8_t>(run ? 1 : 0)};
    lcm_.publish(channels::kDeputyOrder, &o);
  }

  evermap::testing::ScratchDir dir_;
  lcm::LCM lcm_{"memq://"};
  Listener listener_;
  std::unique_ptr<Supervisor> supervisor_;
  std::unique_ptr<DeputyNode> node_;
};

TEST_F(DeputyNodeTest, PublishesStatusOfEveryProcess) {
  CommandSpec c = command("sleeper", "sleep 1000");
  c.group = "pipeline/front";
  makeDeputy({c, command("other", "sleep 1000")});
  ASSERT_TRUE(spinUntil([&] { return !listener_.statuses.empty(); }));
  const deputy_status_t& s = listener_.statuses.back();
  EXPECT_EQ(s.host, "robot");
  ASSERT_EQ(s.num_procs, 2);
  EXPECT_EQ(s.procs[0].name, "sleeper");
  EXPECT_EQ(s.procs[0].group, "pipeline/front");
  EXPECT_EQ(s.procs[0].command, "sleep 1000");
  EXPECT_EQ(s.procs[0].state, kStopped);
  EXPECT_EQ(s.procs[0].desired_running, 0);
  EXPECT_EQ(s.procs[0].pid, 0);
}

TEST_F(DeputyNodeTest, OrdersStartAndStopProcesses) {
  makeDeputy({command("sleeper", "sleep 1000"), command("other", "sleep 1000")});
  order("", "sleeper", true);  // "" addresses every deputy
  ASSERT_TRUE(spinUntil([&] {
    const auto* p = listener_.latest("sleeper");
    return p && p->state == kRunning && p->pid > 0;
  }));
  EXPECT_EQ(listener_.latest("sleeper")->desired_running, 1);
  EXPECT_EQ(listener_.latest("other")->state, kStopped);
  // The sleeper's memory shows once a 1 Hz period has been measured.
  ASSERT_TRUE(spinUntil([&] { return listener_.latest("sleeper")->rss_bytes > 0; }));

  const pid_t pid = listener_.latest("sleeper")->pid;
  order("robot", "sleeper", true);  // the same state again changes nothing
  order("base", "sleeper", false);  // another deputy's order
  order("robot", "nobody", true);   // a name we do not supervise
  ASSERT_TRUE(spinUntil([&] { return node_->counters().unknown_names == 1; }));
  EXPECT_EQ(node_->counters().orders_for_others, 1);
  EXPECT_EQ(supervisor_->status("sleeper")->pid, pid);
  EXPECT_EQ(supervisor_->status("sleeper")->starts, 1);

  order("robot", "sleeper", false);
  ASSERT_TRUE(spinUntil([&] {
    const auto* p = listener_.latest("sleeper");
    return p && p->state == kStopped && p->pid == 0;
  }));
  EXPECT_EQ(listener_.latest("sleeper")->desired_running, 0);
  EXPECT_TRUE(testing::gone(pid));
}

TEST_F(DeputyNodeTest, MalformedOrdersAreCountedAndIgnored) {
  makeDeputy({command("sleeper", "sleep 1000")});
  deputy_order_t o;
  o.host = "";
  o.num_procs = 1;
  o.names = {"sleeper"};
  o.desired_running = {7};
  lcm_.publish(channels::kDeputyOrder, &o);
  ASSERT_TRUE(spinUntil([&] { return node_->counters().orders_malformed == 1; }));
  EXPECT_EQ(supervisor_->status("sleeper")->state, ProcessState::kStopped);
}

TEST_F(DeputyNodeTest, OrdersOf24To49BytesAreCountedAndTheDeputyKeepsSupervising) {
  // Issue 17: a 24-49-byte DEPUTY_ORDER with the right type hash made the deputy abort (the
  // generated decoder threw std::length_error / bad_alloc on a string length of 0 or one
  // beyond the buffer), and its children ran on unsupervised. Now each is one counted line.
  makeDeputy({command("sleeper", "sleep 1000")});
  const uint64_t hash = static_cast<uint64_t>(deputy_order_t::getHash());
  std::mt19937 rng(17);
  int64_t sent = 0;
  for (int size = 24; size <= 49; ++size) {
    for (int fill : {0x00, 0xff, 0x7f, -1}) {
      std::vector<uint8_t> b(static_cast<size_t>(size));
      for (int k = 0; k < 8; ++k) b[k] = static_cast<uint8_t>(hash >> (56 - 8 * k));
      for (int k = 8; k < size; ++k) b[k] = static_cast<uint8_t>(fill < 0 ? rng() : fill);
      lcm_.publish(channels::kDeputyOrder, b.data(), static_cast<unsigned>(size));
      ++sent;
      ASSERT_TRUE(spinUntil(
          [&] { return node_->inbox().counts().at(channels::kDeputyOrder).received == sent; }));
    }
  }
  const DeputyNode::Counters c = node_->counters();
  EXPECT_EQ(c.handler_failed, 0);
  EXPECT_EQ(c.orders_malformed + c.orders_for_others + c.orders_applied, sent);
  EXPECT_GE(c.orders_malformed, 26 * 3);  // the constant fills never decode
  // Still in charge: an order starts the process.
  order("robot", "sleeper", true);
  ASSERT_TRUE(spinUntil([&] {
    const auto* p = listener_.latest("sleeper");
    return p && p->state == kRunning && p->pid != 0;
  }));
}

TEST_F(DeputyNodeTest, PublishesOutputLines) {
  makeDeputy({command("printer", "echo line-1; echo line-2 >&2; sleep 1000")});
  order("", "printer", true);
  ASSERT_TRUE(spinUntil([&] {
    return listener_.allOutput("printer").find("line-1\nline-2\n") != std::string::npos;
  }));
  EXPECT_EQ(listener_.outputs.back().host, "robot");
  EXPECT_NE(listener_.allOutput("printer").find("[deputy] started pid"), std::string::npos);
}

TEST_F(DeputyNodeTest, ReportsRestartsAndExitCodes) {
  makeDeputy({respawning("crasher", "sleep 0.1; exit 5")});
  order("", "crasher", true);
  ASSERT_TRUE(spinUntil([&] {
    const auto* p = listener_.latest("crasher");
    return p && p->restarts >= 2;
  }));
  EXPECT_EQ(listener_.latest("crasher")->last_exit_code, 5);
}

TEST_F(DeputyNodeTest, ClientStartsStopsAndRestartsByNameAndGroup) {
  CommandSpec a = command("a", "sleep 1000");
  a.group = "pipeline";
  CommandSpec b = command("b", "sleep 1000");
  b.group = "pipeline/back";
  CommandSpec once = command("once", "exit 4");
  makeDeputy({a, b, once});
  DeputyClientOptions o;
  o.timeout_s = testing::kGenerousTimeoutS;
  o.settle_s = 0.1;
  DeputyClient client(lcm_, o);
  client.setPump([&] { node_->spinOnce(10); });

  ASSERT_TRUE(client.start({{CtlTarget::Kind::kAuto, "pipeline"}}).ok());
  ASSERT_TRUE(client.waitFor({{CtlTarget::Kind::kGroup, "pipeline"}}, true).ok());
  EXPECT_EQ(supervisor_->status("a")->state, ProcessState::kRunning);
  EXPECT_EQ(supervisor_->status("b")->state, ProcessState::kRunning);
  EXPECT_EQ(supervisor_->status("once")->state, ProcessState::kStopped);

  const pid_t b_pid = supervisor_->status("b")->pid;
  ASSERT_TRUE(client.restart({{CtlTarget::Kind::kCommand, "b"}}).ok());
  ASSERT_TRUE(client.waitFor({{CtlTarget::Kind::kCommand, "b"}}, true).ok());
  ASSERT_TRUE(spinUntil([&] {
    return supervisor_->status("b")->starts == 2 &&
           supervisor_->status("b")->state == ProcessState::kRunning;
  }));
  EXPECT_NE(supervisor_->status("b")->pid, b_pid);

  // A one-shot that failed "should run" already: start re-arms it and it runs again.
  ASSERT_TRUE(client.start({{CtlTarget::Kind::kAuto, "once"}}).ok());
  ASSERT_TRUE(client.waitFor({{CtlTarget::Kind::kAuto, "once"}}, false).ok());
  ASSERT_TRUE(client.start({{CtlTarget::Kind::kAuto, "once"}}).ok());
  ASSERT_TRUE(spinUntil([&] {
    return supervisor_->status("once")->starts == 2 && supervisor_->status("once")->has_ended &&
           supervisor_->status("once")->pid == 0;
  }));
  EXPECT_EQ(supervisor_->status("once")->last_exit_code, 4);

  ASSERT_TRUE(client.stop({{CtlTarget::Kind::kEverything, ""}}).ok());
  ASSERT_TRUE(client.waitFor({{CtlTarget::Kind::kEverything, ""}}, false).ok());
  EXPECT_TRUE(supervisor_->allStopped());

  const auto unknown = client.start({{CtlTarget::Kind::kAuto, "nothing"}});
  ASSERT_FALSE(unknown.ok());
  EXPECT_EQ(unknown.error().message,
            "no command or group \"nothing\" on any deputy (commands: a, b, once; groups: "
            "pipeline, pipeline/back)");
}

TEST_F(DeputyNodeTest, RunsAScriptWithWaits) {
  auto config = parseConfig(R"(
    cmd "prepare" { exec = "echo prepared"; }
    group "pipeline" {
      cmd "worker" { exec = "sleep 1000"; }
      cmd "late" { exec = "sleep 1000"; start_delay_ms = 200; }
    }
    script "go" {
      start cmd "prepare" wait "stopped";
      start group "pipeline" wait "running";
      wait ms 100;
      run_script "halt";
    }
    script "halt" { stop cmd "worker" wait "stopped"; }
  )",
                            "inline.pmd");
  ASSERT_TRUE(config.ok()) << config.error().message;
  makeDeputy(config->commands);
  auto runner = ScriptRunner::create(*config, "go");
  ASSERT_TRUE(runner.ok());
  node_->runScript(std::move(*runner));
  ASSERT_TRUE(spinUntil([&] { return !node_->scriptRunning(); }));
  EXPECT_EQ(supervisor_->status("prepare")->starts, 1);
  EXPECT_EQ(supervisor_->status("prepare")->state, ProcessState::kStopped);
  EXPECT_EQ(supervisor_->status("late")->state, ProcessState::kRunning);
  EXPECT_EQ(supervisor_->status("worker")->state, ProcessState::kStopped);
  EXPECT_EQ(supervisor_->status("worker")->starts, 1);
  EXPECT_FALSE(ScriptRunner::create(*config, "nope").ok());
}

TEST(DeputyStatusTable, ShowsOneRowPerProcess) {
  deputy_status_t s;
  s.host = "robot";
  deputy_proc_t p;
  p.name = "vo-proc";
  p.group = "pipeline";
  p.pid = 1234;
  p.state = kRunning;
  p.desired_running = 0;
  p.restarts = 2;
  p.last_exit_code = -9;
  p.cpu_percent = 45.25;
  p.rss_bytes = 3 * 1024 * 1024;
  s.procs = {p};
  s.num_procs = 1;
  EXPECT_EQ(formatStatusTable({s}, true),
            "HOST\tNAME\tGROUP\tSTATE\tDESIRED\tPID\tCPU%\tRSS_MB\tRESTARTS\tLAST_EXIT\n"
            "robot\tvo-proc\tpipeline\tstopping\tstop\t1234\t45.2\t3.0\t2\t-9\n");
  const std::string table = formatStatusTable({s}, false);
  EXPECT_EQ(table.substr(0, table.find('\n')),
            "HOST   NAME     GROUP     STATE     DESIRED  PID   CPU%  RSS_MB  RESTARTS  LAST_EXIT");
}

}  // namespace
}  // namespace evermap::deputy
