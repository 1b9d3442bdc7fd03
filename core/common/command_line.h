#pragma once
// The command line of an evermap program: options declared once with their help text, parsed
// into the caller's variables, with the usage text generated from the same declarations.
//
//   CommandLine cli("evermap-map-render", "Draws a map store with its floors stacked.");
//   std::string store;  double z_gap_m = 4.0;  bool quiet = false;
//   cli.value("--store", &store, "MAP.db", "the map store to draw", /*required=*/true);
//   cli.value("--z-gap", &z_gap_m, "M", "vertical distance drawn between floors, metres");
//   cli.flag("--quiet", &quiet, "print nothing");
//   if (const int code = cli.parseOrExit(argc, argv); code >= 0) return code;
//
// Conventions shared by every tool: `--name value` (or `--name=value`), `--help` prints the
// usage on stdout and exits 0, and a bad command line is one line on stderr naming the
// option, followed by the usage, exit status 2.

#include <charconv>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "core/common/expected.h"
#include "core/common/option_fields.h"

namespace evermap {

class CommandLine {
 public:
  // The range of a numeric option (core/common/option_fields.h), checked when the option is
  // parsed: a value outside it is a bad command line naming the option and the range ("bad
  // --queue: -5 is outside [1, 1000]"). Every numeric value() returns one, [[nodiscard]], so
  // an option declared without its range warns at compile time: say .min(), .max(),
  // .positive(), .in() or, where every number means something (a seed, an angle), .any().
  using Range = OptionRange;

  CommandLine(std::string program, std::string summary);

  // A string, number or boolean option that takes a value. Numbers must parse completely,
  // be finite and lie in their Range. `required` options must be given.
  void value(std::string name, std::string* out, std::string metavar, std::string help,
             bool required = false);
  [[nodiscard("give the option its range: .min(), .max(), .positive() or .any()")]] Range value(
      std::string name, double* out, std::string metavar, std::string help, bool required = false);
  template <typename Int>
  requires(std::is_integral_v<Int> && !std::is_same_v<Int, bool>)
      [[nodiscard("give the option its range: .min(), .max(), .positive() or .any()")]] Range
      value(std::string name, Int* out, std::string metavar, std::string help,
            bool required = false) {
    auto limits = std::make_shared<OptionRange::Limits>();
    add(std::move(name), std::move(metavar), std::move(help), required).set =
        [out, limits](const std::string& v) -> Status {
      Int n{};
      if (Status s = option_text::parseInteger(v, &n); !s) return s;
      if (Status s = Range(limits).check(static_cast<double>(n)); !s) return s;
      *out = n;
      return Ok{};
    };
    return Range(limits);
  }
  // A value checked by the caller: `set` returns an error message for a bad value.
  void value(std::string name, std::function<Status(const std::string&)> set, std::string metavar,
             std::string help, bool required = false);
  // An option that may be given several times: each value is appended to `*out`.
  void repeated(std::string name, std::vector<std::string>* out, std::string metavar,
                std::string help);
  // An option without a value; sets `*out` to true.
  void flag(std::string name, bool* out, std::string help);
  // The declared options of an options struct (core/common/option_fields.h), keys prefixed
  // with `prefix`: the program takes --config FILE (`key = value` lines, read first),
  // --set KEY=VALUE (repeatable, applied after the file, in order) and --print-config (prints
  // the values in effect as a config file and exits 0), and --help lists every option with
  // its default, unit, allowed values and doc. May be called for several structs; a program
  // that declared --config or --set itself (a file shared with other settings) keeps its own
  // and loads optionList() itself.
  template <typename Options>
  void options(Options* o, const std::string& prefix = "") {
    options(OptionList::of(o, prefix));
  }
  void options(OptionList list);
  OptionList& optionList() { return option_list_; }
  // A flag of its own for an option declared through options(), the short form command lines
  // already use: `--name VALUE` is `--set key=VALUE` (with an empty metavar, `--name` alone is
  // `--set key=flag_value`). The value is checked when parsed (an error names --name and the
  // allowed values) and applied in order with the --set list, after --config. Its help line
  // is the option's doc, default, unit and allowed values. Declare after options().
  void alias(std::string name, const std::string& key, std::string metavar,
             std::string flag_value = "true");
  // Another name for --print-config, kept for command lines that use it (--print-options).
  void printConfigAlias(std::string name) {
    flag(std::move(name), &print_config_, "the same as --print-config");
  }
  // A rule checked after the options are set (a struct's validate(): the rules between
  // fields), before --print-config prints them; its error is a bad command line.
  void check(std::function<Status()> rule) { checks_.push_back(std::move(rule)); }
  // Words that are not options go here (in order); without this, they are errors.
  void positional(std::vector<std::string>* out, std::string metavar, std::string help);

  // Parses argv[1..]. Errors are one line naming the option.
  // kPrintConfig: --print-config was given (the options are set). kHelpMarkdown:
  // --help-markdown, the usage as a section of docs/options.md.
  enum class Outcome { kRun, kHelp, kPrintConfig, kHelpMarkdown };
  Expected<Outcome> parse(int argc, const char* const* argv);

  // parse() with the conventions above: returns -1 to run, or the exit status to return
  // from main (0 after --help, --help-markdown or --print-config, 2 after an error, all
  // already printed).
  int parseOrExit(int argc, const char* const* argv);

  // The flags and every option (--help).
  std::string usage() const;
  // The flags only (after a bad command line).
  std::string flagUsage() const;
  // The program, its flags and its options as Markdown (docs/options.md).
  std::string markdown() const;
  // For a process's log at its start: the declared options whose values are not their
  // defaults, each with where it came from (the last --set or alias flag that set it, else
  // the --config file), as one line ("evermap-vo-proc: options not at their defaults:
  // odometry.line_delay_us = 28.3 (config/vo-proc.cfg)"); empty when none.
  std::string changedOptionsLine() const;
  // Prints changedOptionsLine() on stderr, if not empty.
  void logChangedOptions() const;
  const std::string& program() const { return program_; }

 private:
  struct Option {
    std::string name;
    std::string metavar;  // empty for flags
    std::string help;
    bool required = false;
    bool seen = false;
    std::function<Status(const std::string&)> set;
    std::string alias_of;    // the key of option_list_ an alias() sets
    std::string flag_value;  // ... to this, for an alias without a value
  };
  Option& add(std::string name, std::string metavar, std::string help, bool required);
  bool declared(const std::string& name) const;
  // An alias()'s value into its option, and onto the --set list.
  Status setAlias(const std::string& name, const std::string& key, const std::string& value);
  // Where option `key`'s value came from (changedOptionsLine).
  std::string sourceOf(const std::string& key) const;
  // --config, then the --set list, into option_list_.
  Status applyOptions();

  std::string program_;
  std::string summary_;
  std::vector<Option> options_;
  std::vector<std::string>* positional_ = nullptr;
  std::string positional_metavar_;
  std::string positional_help_;
  OptionList option_list_;
  bool options_own_config_ = false;  // --config/--set/--print-config come from options()
  std::string config_file_;
  std::vector<std::string> config_sets_;
  std::map<size_t, std::string> alias_of_set_;  // config_sets_ index -> the alias flag given
  bool print_config_ = false;
  std::vector<std::function<Status()>> checks_;
};

}  // namespace evermap
