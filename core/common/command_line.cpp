#include "core/common/command_line.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <utility>

namespace evermap {
CommandLine::CommandLine(std::string program, std::string summary)
    : program_(std::move(program)), summary_(std::move(summary)) {}

CommandLine::Option& CommandLine::add(std::string name, std::string metavar, std::string help,
                                      bool required) {
  if (name.size() < 3 || name.compare(0, 2, "--") != 0) {
    std::fprintf(stderr, "CommandLine: option name \"%s\" must start with --\n", name.c_str());
    std::abort();
  }
  for (const Option& o : options_) {
    if (o.name == name) {
      std::fprintf(stderr, "CommandLine: option %s declared twice\n", name.c_str());
      std::abort();
    }
  }
  Option o;
  o.name = std::move(name);
  o.metavar = std::move(metavar);
  o.help = std::move(help);
  o.required = required;
  options_.push_back(std::move(o));
  return options_.back();
}

void CommandLine::value(std::string name, std::string* out, std::string metavar, std::string help,
                        bool required) {
  add(std::move(name), std::move(metavar), std::move(help), required).set =
      [out](const std::string& v) -> Status {
    *out = v;
    return Ok{};
  };
}

CommandLine::Range CommandLine::value(std::string name, double* out, std::string metavar,
                                      std::string help, bool required) {
  auto limits = std::make_shared<OptionRange::Limits>();
  add(std::move(name), std::move(metavar), std::move(help), required).set =
      [out, limits](const std::string& v) -> Status {
    char* end = nullptr;
    const double d = std::strtod(v.c_str(), &end);
    if (v.empty() || *end != '\0' || !std::isfinite(d)) {
      return makeError("\"", v, "\" is not a finite number");
    }
    if (Status s = Range(limits).check(d); !s) return s;
    *out = d;
    return Ok{};
  };
  return Range(limits);
}

void CommandLine::repeated(std::string name, std::vector<std::string>* out, std::string metavar,
                           std::string help) {
  add(std::move(name), std::move(metavar), std::move(help), false).set =
      [out](const std::string& v) -> Status {
    out->push_back(v);
    return Ok{};
  };
}

void CommandLine::value(std::string name, std::function<Status(const std::string&)> set,
                        std::string metavar, std::string help, bool required) {
  add(std::move(name), std::move(metavar), std::move(help), required).set = std::move(set);
}

void CommandLine::flag(std::string name, bool* out, std::string help) {
  add(std::move(name), "", std::move(help), false).set = [out](const std::string&) -> Status {
    *out = true;
    return Ok{};
  };
}

void CommandLine::positional(std::vector<std::string>* out, std::string metavar, std::string help) {
  positional_ = out;
  positional_metavar_ = std::move(metavar);
  positional_help_ = std::move(help);
}

bool CommandLine::declared(const std::string& name) const {
  return std::any_of(options_.begin(), options_.end(),
                     [&name](const Option& o) { return o.name == name; });
}

void CommandLine::options(OptionList list) {
  option_list_.append(std::move(list));
  if (declared("--config") || declared("--set") || declared("--print-config")) return;
  options_own_config_ = true;
  value("--config", &config_file_, "FILE", "read options from FILE (key = value lines)");
  repeated("--set", &config_sets_, "KEY=VALUE", "set one option (after --config; repeatable)");
  flag("--print-config", &print_config_, "print the options in effect and exit");
}

void CommandLine::alias(std::string name, const std::string& key, std::string metavar,
                        std::string flag_value) {
  const OptionField* f = option_list_.find(key);
  if (!f) {
    std::fprintf(stderr, "CommandLine: %s: no option %s declared before it\n", name.c_str(),
                 key.c_str());
    std::abort();
  }
  const bool flag = metavar.empty();
  const std::string help = f->doc + " [" + (f->default_text.empty() ? "\"\"" : f->default_text) +
                           (f->unit.empty() ? "" : " " + f->unit) + "; " + f->allowedText() +
                           "] (--set " + key + (flag ? "=" + flag_value : "") + ")";
  Option& o = add(std::move(name), std::move(metavar), help, false);
  o.alias_of = key;
  o.flag_value = std::move(flag_value);
}

Status CommandLine::setAlias(const std::string& name, const std::string& key,
                             const std::string& value) {
  if (Status s = option_list_.find(key)->set(value); !s) return s;
  alias_of_set_[config_sets_.size()] = name;
  config_sets_.push_back(key + "=" + value);  // again after --config, in order with --set
  return Ok{};
}

Status CommandLine::applyOptions() {
  if (!options_own_config_) return Ok{};
  OptionList& list = option_list_;
  if (!config_file_.empty()) {
    if (Status s = list.loadFile(config_file_); !s) return s;
  }
  for (const std::string& assignment : config_sets_) {
    if (Status s = list.assign(assignment); !s) return makeError("bad --set: ", s.error().message);
  }
  return Ok{};
}

std::string CommandLine::sourceOf(const std::string& key) const {
  for (size_t i = config_sets_.size(); i-- > 0;) {
    if (OptionList::keyOf(config_sets_[i]) != key) continue;
    const auto alias = alias_of_set_.find(i);
    return alias != alias_of_set_.end() ? alias->second : "--set";
  }
  return config_file_.empty() ? "set by the program" : config_file_;
}

std::string CommandLine::changedOptionsLine() const {
  std::string line;
  for (const auto& [key, value] : option_list_.changed()) {
    line += (line.empty() ? "" : ", ") + key + " = " + value + " (" + sourceOf(key) + ")";
  }
  return line.empty() ? line : program_ + ": options not at their defaults: " + line;
}

void CommandLine::logChangedOptions() const {
  if (const std::string line = changedOptionsLine(); !line.empty()) {
    std::fprintf(stderr, "%s\n", line.c_str());
  }
}

Expected<CommandLine::Outcome> CommandLine::parse(int argc, const char* const* argv) {
  for (Option& o : options_) o.seen = false;
  for (int i = 1; i < argc; ++i) {
    std::string arg = argv[i];
    if (arg == "--help" || arg == "-h") return Outcome::kHelp;
    if (arg == "--help-markdown") return Outcome::kHelpMarkdown;
    if (arg.size() < 2 || arg[0] != '-') {
      if (!positional_) return makeError("unexpected argument \"", arg, "\"");
      positional_->push_back(arg);
      continue;
    }
    std::string inline_value;
    bool has_inline = false;
    if (const auto eq = arg.find('='); eq != std::string::npos && arg.compare(0, 2, "--") == 0) {
      inline_value = arg.substr(eq + 1);
      arg.resize(eq);
      has_inline = true;
    }
    Option* option = nullptr;
    for (Option& o : options_) {
      if (o.name == arg) option = &o;
    }
    if (!option) return makeError("unknown option ", arg);
    std::string value;
    if (option->metavar.empty()) {
      if (has_inline) return makeError(arg, " takes no value");
    } else if (has_inline) {
      value = inline_value;
    } else {
      if (i + 1 >= argc) return makeError(arg, " needs a value (", option->metavar, ")");
      value = argv[++i];
    }
    if (!option->alias_of.empty() && option->metavar.empty()) value = option->flag_value;
    const Status set = option->alias_of.empty() ? option->set(value)
                                                : setAlias(option->name, option->alias_of, value);
    if (!set) return makeError("bad ", arg, ": ", set.error().message);
    option->seen = true;
  }
  if (Status s = applyOptions(); !s) return Error{s.error()};
  for (const auto& rule : checks_) {
    if (Status s = rule(); !s) return Error{s.error()};
  }
  if (print_config_) return Outcome::kPrintConfig;
  for (const Option& o : options_) {
    if (o.required && !o.seen) return makeError(o.name, " is required");
  }
  return Outcome::kRun;
}

int CommandLine::parseOrExit(int argc, const char* const* argv) {
  const Expected<Outcome> outcome = parse(argc, argv);
  if (!outcome) {
    std::fprintf(stderr, "%s: %s\n%s", program_.c_str(), outcome.error().message.c_str(),
                 flagUsage().c_str());
    if (!option_list_.fields().empty()) {
      std::fprintf(stderr, "(%s --help lists its %zu options)\n", program_.c_str(),
                   option_list_.fields().size());
    }
    return 2;
  }
  switch (*outcome) {
    case Outcome::kHelp:
      std::fputs(usage().c_str(), stdout);
      return 0;
    case Outcome::kHelpMarkdown:
      std::fputs(markdown().c_str(), stdout);
      return 0;
    case Outcome::kPrintConfig:
      std::fputs(option_list_.print().c_str(), stdout);
      return 0;
    case Outcome::kRun:
      break;
  }
  return -1;
}

std::string CommandLine::usage() const {
  std::string text = flagUsage();
  if (!option_list_.fields().empty()) {
    text += "options (--set KEY=VALUE or KEY = VALUE in --config FILE; default, unit, allowed):\n";
    text += option_list_.help();
  }
  return text;
}

std::string CommandLine::flagUsage() const {
  std::string text = "usage: " + program_;
  for (const Option& o : options_) {
    std::string item = o.name + (o.metavar.empty() ? "" : " " + o.metavar);
    text += o.required ? " " + item : " [" + item + "]";
  }
  if (positional_) text += " " + positional_metavar_;
  text += "\n";
  if (!summary_.empty()) text += summary_ + "\n";
  size_t width = positional_ ? positional_metavar_.size() : 0;
  for (const Option& o : options_) {
    width = std::max(width, o.name.size() + (o.metavar.empty() ? 0 : o.metavar.size() + 1));
  }
  auto line = [&](const std::string& left, const std::string& help) {
    text += "  " + left + std::string(width - left.size() + 2, ' ') + help + "\n";
  };
  if (positional_) line(positional_metavar_, positional_help_);
  for (const Option& o : options_) {
    line(o.name + (o.metavar.empty() ? "" : " " + o.metavar), o.help);
  }
  return text;
}

std::string CommandLine::markdown() const {
  std::string text = "## " + program_ + "\n\n" + summary_ + "\n\n| flag | meaning |\n|---|---|\n";
  if (positional_) text += "| `" + positional_metavar_ + "` | " + positional_help_ + " |\n";
  for (const Option& o : options_) {
    const std::string left = o.name + (o.metavar.empty() ? "" : " " + o.metavar);
    text += "| `" + left + "` | " + o.help + (o.required ? " (required)" : "") + " |\n";
  }
  if (!option_list_.fields().empty()) {
    text += '\n';
    text += option_list_.markdown();
  }
  text += '\n';
  return text;
}

}  // namespace evermap
