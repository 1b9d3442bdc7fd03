// The procman configuration parser: the format as bot2-procman documents it, our addition,
// and malformed input refused with file:line:column.
#include <gtest/gtest.h>

#include <fstream>

#include "scratch_dir.h"
#include "tools/deputy/config.h"

namespace evermap::deputy {
namespace {

// The example of bot2-procman's config_file.md, with its nested groups and script.
constexpr const char* kProcmanExample = R"(# a hash mark indicates a comment.
cmd "load configuration" {
    # This command loads the robot configuration, and then exits.
    exec = "configure_robot";
    host = "robot";
}
cmd "hardware interface" {
    exec = "hw_interface";
    host = "robot";
    auto_respawn = "true";
}
group "planning and perception" {
    cmd "planner" {
        exec = "planner";
        host = "robot";
        stop_signal = 15;
        stop_time_allowed = 20;
    }
    group "sensing" {
        group "cameras" {
            cmd "left camera" { exec = "left_camera --id 0"; host = "robot"; }
        }
        cmd "perception" { exec = "perception"; host = "other"; }
    }
}
script "go" {
    start cmd "load configuration" wait "stopped";
    start cmd "hardware interface";
    wait ms 1000;
    start group "planning and perception";
    start group "planning and perception/sensing/cameras" wait "running";
    run_script "halt";
}
script "halt" {
    stop everything wait "stopped";
    restart cmd "planner" wait "running";
    wait group "planning and perception" status "running";
}
)";

Config parseOk(const std::string& text) {
  auto c = parseConfig(text, "test.pmd");
  EXPECT_TRUE(c.ok()) << (c.ok() ? "" : c.error().message);
  return c.ok() ? *c : Config{};
}

std::string parseError(const std::string& text) {
  auto c = parseConfig(text, "bad.pmd");
  EXPECT_FALSE(c.ok()) << "accepted:\n" << text;
  return c.ok() ? "" : c.error().message;
}

TEST(DeputyConfig, ReadsProcmanDocumentationExample) {
  const Config c = parseOk(kProcmanExample);
  ASSERT_EQ(c.commands.size(), 5u);
  const CommandSpec* load = c.findCommand("load configuration");
  ASSERT_NE(load, nullptr);
  EXPECT_EQ(load->exec, "configure_robot");
  EXPECT_EQ(load->host, "robot");
  EXPECT_EQ(load->group, "");
  EXPECT_FALSE(load->auto_respawn);
  EXPECT_EQ(load->stop_signal, 2);  // procman's defaults
  EXPECT_EQ(load->stop_time_allowed_s, 7);
  EXPECT_EQ(load->pos.line, 2);
  EXPECT_TRUE(c.findCommand("hardware interface")->auto_respawn);
  const CommandSpec* planner = c.findCommand("planner");
  EXPECT_EQ(planner->group, "planning and perception");
  EXPECT_EQ(planner->stop_signal, 15);
  EXPECT_EQ(planner->stop_time_allowed_s, 20);
  EXPECT_EQ(c.findCommand("left camera")->group, "planning and perception/sensing/cameras");
  EXPECT_EQ(c.findCommand("left camera")->exec, "left_camera --id 0");
}

TEST(DeputyConfig, NestedGroupsContainTheirSubgroupsCommands) {
  const Config c = parseOk(kProcmanExample);
  EXPECT_TRUE(c.hasGroup("planning and perception/sensing"));
  EXPECT_TRUE(c.hasGroup("/planning and perception//sensing/"));  // procman's spellings
  EXPECT_FALSE(c.hasGroup("sensing"));
  EXPECT_EQ(c.commandsInGroup("planning and perception"),
            (std::vector<std::string>{"planner", "left camera", "perception"}));
  EXPECT_EQ(c.commandsInGroup("planning and perception/sensing"),
            (std::vector<std::string>{"left camera", "perception"}));
  // "planning" is a prefix of the name, not a group.
  EXPECT_TRUE(c.commandsInGroup("planning").empty());
}

TEST(DeputyConfig, ScriptsKeepEveryActionInOrder) {
  const Config c = parseOk(kProcmanExample);
  ASSERT_EQ(c.scripts.size(), 2u);
  const Script* go = c.findScript("go");
  ASSERT_NE(go, nullptr);
  ASSERT_EQ(go->actions.size(), 6u);
  using K = ScriptAction::Kind;
  EXPECT_EQ(go->actions[0].kind, K::kStart);
  EXPECT_EQ(go->actions[0].target_kind, TargetKind::kCommand);
  EXPECT_EQ(go->actions[0].target, "load configuration");
  EXPECT_EQ(go->actions[0].wait, WaitFor::kStopped);
  EXPECT_EQ(go->actions[1].wait, WaitFor::kNothing);
  EXPECT_EQ(go->actions[2].kind, K::kWaitMs);
  EXPECT_EQ(go->actions[2].delay_ms, 1000);
  EXPECT_EQ(go->actions[3].target_kind, TargetKind::kGroup);
  EXPECT_EQ(go->actions[4].target, "planning and perception/sensing/cameras");
  EXPECT_EQ(go->actions[4].wait, WaitFor::kRunning);
  EXPECT_EQ(go->actions[5].kind, K::kRunScript);
  EXPECT_EQ(go->actions[5].target, "halt");
  const Script* halt = c.findScript("halt");
  EXPECT_EQ(halt->actions[0].kind, K::kStop);
  EXPECT_EQ(halt->actions[0].target_kind, TargetKind::kEverything);
  EXPECT_EQ(halt->actions[1].kind, K::kRestart);
  EXPECT_EQ(halt->actions[2].kind, K::kWaitStatus);
  EXPECT_EQ(halt->actions[2].wait, WaitFor::kRunning);
  EXPECT_EQ(halt->actions[2].pos.line, 37);
}

TEST(DeputyConfig, ReadsStartDelayAndEscapes) {
  const Config c = parseOk(
      "cmd \"a\" { exec = \"echo \\\"hi\\\" \\\\ x\\ty\"; start_delay_ms = 1500; }\n"
      "cmd { exec = \"unnamed --x\"; }\n");
  EXPECT_EQ(c.findCommand("a")->exec, "echo \"hi\" \\ x\ty");
  EXPECT_EQ(c.findCommand("a")->start_delay_ms, 1500);
  // A command without a name is named by its exec string, as procman's sheriff does.
  ASSERT_NE(c.findCommand("unnamed --x"), nullptr);
}

TEST(DeputyConfig, ChoosesCommandsByHost) {
  const Config c = parseOk(
      "cmd \"a\" { exec = \"a\"; host = \"robot\"; }\n"
      "cmd \"b\" { exec = \"b\"; host = \"base\"; }\n"
      "cmd \"c\" { exec = \"c\"; }\n"
      "cmd \"d\" { exec = \"d\"; host = \"localhost\"; }\n");
  std::vector<std::string> names;
  for (const auto& cmd : c.commandsForHost("robot")) names.push_back(cmd.name);
  EXPECT_EQ(names, (std::vector<std::string>{"a", "c", "d"}));
}

TEST(DeputyConfig, FormatsBackToAnEquivalentConfig) {
  const Config c = parseOk(kProcmanExample);
  const std::string text = formatConfig(c);
  const Config again = parseOk(text);
  EXPECT_EQ(formatConfig(again), text);
  ASSERT_EQ(again.commands.size(), c.commands.size());
  for (const CommandSpec& cmd : c.commands) {
    const CommandSpec* other = again.findCommand(cmd.name);
    ASSERT_NE(other, nullptr) << cmd.name;
    EXPECT_EQ(other->exec, cmd.exec);
    EXPECT_EQ(other->group, cmd.group);
    EXPECT_EQ(other->host, cmd.host);
    EXPECT_EQ(other->auto_respawn, cmd.auto_respawn);
    EXPECT_EQ(other->stop_signal, cmd.stop_signal);
    EXPECT_EQ(other->stop_time_allowed_s, cmd.stop_time_allowed_s);
  }
  EXPECT_EQ(again.scripts.size(), 2u);
  EXPECT_EQ(again.findScript("go")->actions.size(), 6u);
}

TEST(DeputyConfig, MalformedInputNamesFileLineAndColumn) {
  EXPECT_EQ(parseError("cmd \"a\" {\n  exec = \"x\"\n}\n"),
            "bad.pmd:3:1: expected ';' after the value of exec, got '}' (})");
  EXPECT_EQ(parseError("cmd \"a\" { exec = \"x\"; colour = \"red\"; }"),
            "bad.pmd:1:23: unknown command attribute 'colour' (exec, host, group, auto_respawn, "
            "stop_signal, stop_time_allowed, start_delay_ms)");
  EXPECT_EQ(parseError("\n\n  cmd \"a\" { exec = \"unterminated; }\n"),
            "bad.pmd:3:20: unterminated string");
  EXPECT_EQ(parseError("cmd \"a\" { exec = \"x\"; stop_signal = \"15\"; }"),
            "bad.pmd:1:37: stop_signal takes an integer");
  EXPECT_EQ(parseError("cmd \"a\" { exec = \"x\"; stop_time_allowed = 0; }"),
            "bad.pmd:1:43: stop_time_allowed must be in [1, 86400], got 0");
  EXPECT_EQ(parseError("cmd \"a\" { exec = \"x\"; auto_respawn = \"yes\"; }"),
            "bad.pmd:1:38: auto_respawn must be \"true\" or \"false\", got \"yes\"");
  EXPECT_EQ(parseError("cmd \"a\" { host = \"robot\"; }"),
            "bad.pmd:1:27: command \"a\" has no exec");
  EXPECT_EQ(parseError("cmd \"a\" { exec = \"x\"; stop_signal = -2; }"),
            "bad.pmd:1:37: unexpected character '-'");
  EXPECT_EQ(parseError("group \"g\" {\n  cmd \"a\" { exec = \"x\"; }\n"),
            "bad.pmd:3:1: expected '}' closing group \"g\", got end of file");
  EXPECT_EQ(parseError("group \"g\" { script \"s\" { } }"),
            "bad.pmd:1:13: expected cmd or group, got a word (script)");
  EXPECT_EQ(parseError("group \"a/b\" { }"), "bad.pmd:1:7: '/' is not allowed in a group name");
  EXPECT_EQ(parseError("process \"a\" { }"),
            "bad.pmd:1:1: expected cmd or group or script, got a word (process)");
}

TEST(DeputyConfig, RefusesDuplicatesAndUnknownReferences) {
  EXPECT_EQ(
      parseError("cmd \"a\" { exec = \"x\"; }\ngroup \"g\" {\n  cmd \"a\" { exec = \"y\"; }\n}"),
      "bad.pmd:3:7: duplicate command name \"a\" (first at line 1)");
  EXPECT_EQ(parseError("script \"s\" { }\nscript \"s\" { }"),
            "bad.pmd:2:8: duplicate script name \"s\" (first at line 1)");
  EXPECT_EQ(parseError("cmd \"a\" { exec = \"x\"; }\nscript \"s\" {\n  start cmd \"b\";\n}"),
            "bad.pmd:3:3: unknown command \"b\"");
  EXPECT_EQ(parseError("script \"s\" {\n  stop group \"nope\" wait \"stopped\";\n}"),
            "bad.pmd:2:3: unknown group \"nope\"");
  EXPECT_EQ(parseError("script \"s\" { run_script \"t\"; }"),
            "bad.pmd:1:14: script \"s\" runs unknown script \"t\"");
  EXPECT_EQ(
      parseError("cmd \"a\" { exec = \"x\"; }\nscript \"s\" { start cmd \"a\" wait \"done\"; }"),
      "bad.pmd:2:33: expected \"running\" or \"stopped\", got \"done\"");
  EXPECT_EQ(
      parseError("cmd \"a\" { exec = \"x\"; }\nscript \"s\" { stop cmd \"a\" wait \"running\"; }"),
      "bad.pmd:2:32: a stop can only wait for \"stopped\"");
  EXPECT_EQ(parseError("script \"s\" { wait ms; }"),
            "bad.pmd:1:21: expected milliseconds, got ';' (;)");
}

TEST(DeputyConfig, RefusesScriptsThatCallThemselves) {
  EXPECT_EQ(parseError("script \"a\" { run_script \"b\"; }\nscript \"b\" {\n  wait ms 1;\n"
                       "  run_script \"a\";\n}"),
            "bad.pmd:4:3: script \"b\" calls \"a\", which leads back to it");
}

TEST(DeputyConfig, LoadingAMissingFileNamesIt) {
  auto c = loadConfig("/nonexistent/pipeline.pmd");
  ASSERT_FALSE(c.ok());
  EXPECT_EQ(c.error().message, "/nonexistent/pipeline.pmd: cannot open");
}

TEST(DeputyConfig, ErrorsFromAFileNameTheFile) {
  testing::ScratchDir dir;
  std::ofstream(dir / "x.pmd") << "cmd \"a\" {\n  exec = 3;\n}\n";
  auto c = loadConfig(dir / "x.pmd");
  ASSERT_FALSE(c.ok());
  EXPECT_EQ(c.error().message, (dir / "x.pmd").string() + ":2:10: exec takes a quoted string");
}

TEST(DeputyConfig, ReadsEveryShippedConfig) {
  int n = 0;
  for (const auto& e :
       std::filesystem::directory_iterator(std::filesystem::path(EVERMAP_SOURCE_DIR) / "config")) {
    if (e.path().extension() != ".pmd") continue;
    auto c = loadConfig(e.path());
    EXPECT_TRUE(c.ok()) << c.error().message;
    ++n;
  }
  EXPECT_GE(n, 3);
}

TEST(DeputyConfig, ReadsTheShippedPipelineConfigs) {
  for (const char* name : {"pipeline-log.pmd", "pipeline-oracle.pmd"}) {
    const auto path = std::filesystem::path(EVERMAP_SOURCE_DIR) / "config" / name;
    auto c = loadConfig(path);
    ASSERT_TRUE(c.ok()) << c.error().message;
    EXPECT_NE(c->findCommand("mapper-proc"), nullptr) << name;
    EXPECT_NE(c->findScript("go"), nullptr) << name;
  }
}

}  // namespace
}  // namespace evermap::deputy
