#include "core/common/command_line.h"

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

CommandLine::Range& CommandLine::Range::min(double lo) {
  limits_->lo = lo;
  limits_->lo_open = false;
  return *this;
}
CommandLine::Range& CommandLine::Range::max(double hi) {
  limits_->hi = hi;
  return *this;
}
CommandLine::Range& CommandLine::Range::positive() {
  limits_->lo = 0.0;
  limits_->lo_open = true;
  return *this;
}

Status CommandLine::Range::check(double v) const {
  const Limits& l = *limits_;
  const std::string text = numberText(v, 10);
  if (l.lo_open && !(v > l.lo)) return makeError(text, " is not above ", numberText(l.lo, 10));
  if (!l.lo_open && v < l.lo)
    return makeError(text, " is below the minimum ", numberText(l.lo, 10));
  if (v > l.hi) return makeError(text, " is above the maximum ", numberText(l.hi, 10));
  return Ok{};
}

CommandLine::Range CommandLine::value(std::string name, double* out, std::string metavar,
                                      std::string help, bool required) {
  auto limits = std::make_shared<Range::Limits>();
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

Expected<CommandLine::Outcome> CommandLine::parse(int argc, const char* const* argv) {
  for (Option& o : options_) o.seen = false;
  for (int i = 1; i < argc; ++i) {
    std::string arg = argv[i];
    if (arg == "--help" || arg == "-h") return Outcome::kHelp;
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
    if (Status s = option->set(value); !s) return makeError("bad ", arg, ": ", s.error().message);
    option->seen = true;
  }
  for (const Option& o : options_) {
    if (o.required && !o.seen) return makeError(o.name, " is required");
  }
  return Outcome::kRun;
}

int CommandLine::parseOrExit(int argc, const char* const* argv) {
  const Expected<Outcome> outcome = parse(argc, argv);
  if (!outcome) {
    std::fprintf(stderr, "%s: %s\n%s", program_.c_str(), outcome.error().message.c_str(),
                 usage().c_str());
    return 2;
  }
  if (*outcome == Outcome::kHelp) {
    std::fputs(usage().c_str(), stdout);
    return 0;
  }
  return -1;
}

std::string CommandLine::usage() const {
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

}  // namespace evermap
