#pragma once
// One way to declare an option. An options struct declares each of its fields once, with its
// key, unit, allowed range and one line of doc; the struct's member initialiser is the
// default:
//
//   struct GateOptions {
//     double max_gap_s = 2.0;
//     Mode mode = Mode::kFast;
//     SubOptions sub;
//     void declareOptions(OptionList& o) {
//       o.add("max_gap_s", &max_gap_s, "s", "longest gap bridged").positive();
//       o.choice("mode", &mode, {{"fast", Mode::kFast}, {"exact", Mode::kExact}}, "how");
//       o.nest("sub.", &sub);
//     }
//   };
//
// OptionList::of(&options, "gate.") binds the declaration to one instance (and reads the
// defaults from a default-constructed struct). From it come: set("gate.max_gap_s", "3") and
// loadFile(path) (config files of `key = value` lines, '#' comments, errors naming
// file:line, unknown keys refused), checkRanges(), print() (the values in effect, readable
// back as a config file), help() and markdown() (every option with default, unit, range and
// doc). CommandLine::options() gives a program --config, --set, --print-config and the
// list in --help. Single-field ranges live in the declaration; rules that tie fields
// together stay in the struct's validate() (which calls checkOptionRanges(*this) first).

#include <charconv>
#include <cmath>
#include <cstdio>
#include <concepts>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "core/common/expected.h"

namespace evermap {

class KeyValueFile;

// The allowed values of a numeric option: an interval, closed or open at either end, or
// every number (.any()). A range is what the option means, not a tuning: "> 0" for a
// length, "[0, 1]" for a fraction.
class OptionRange {
 public:
  OptionRange& min(double lo);    // value >= lo
  OptionRange& above(double lo);  // value > lo
  OptionRange& max(double hi);    // value <= hi
  OptionRange& below(double hi);  // value < hi
  OptionRange& positive() { return above(0.0); }
  OptionRange& nonNegative() { return min(0.0); }
  OptionRange& in(double lo, double hi) { return min(lo).max(hi); }
  OptionRange& any() { return *this; }

  bool contains(double v) const;
  // "> 0", ">= 1", "[0, 3]", "(0, 10]", "any".
  std::string text() const;
  // Ok, or "<v> is outside <text>".
  Status check(double v) const;

  struct Limits {
    double lo = -INFINITY, hi = INFINITY;
    bool lo_open = false, hi_open = false;
  };
  explicit OptionRange(std::shared_ptr<Limits> limits) : limits_(std::move(limits)) {}

 private:
  std::shared_ptr<Limits> limits_;
};

// One declared option, bound to a field of one instance.
struct OptionField {
  std::string key;      // with its prefix: "mapper.tracker.history_s"
  std::string unit;     // "m", "s", "m/s^2"; empty for a count or a ratio
  std::string doc;      // one line
  std::string allowed;  // of a non-numeric field: "gn | dogleg", "true | false"
  std::shared_ptr<OptionRange::Limits> range;  // of a numeric field
  std::string default_text;  // the value of a default-constructed struct (OptionList::of)
  std::function<std::string()> get;
  // Parses `text` and checks it against the range, then stores it; the error says why, not
  // which option (the caller adds the key).
  std::function<Status(const std::string&)> set;
  // The current value against the range.
  std::function<Status()> check;

  // The allowed values as text: the range ("[0, 3]") or `allowed`.
  std::string allowedText() const;
};

// The text of option values as they are printed and parsed.
namespace option_text {
std::string ofDouble(double v);  // shortest text that reads back to the same double
Status parseDouble(const std::string& text, double* out);
Status parseBool(const std::string& text, bool* out);
template <std::integral Int>
Status parseInteger(const std::string& text, Int* out) {
  Int v{};
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, v);
  if (text.empty() || ec != std::errc() || ptr != end) {
    return makeError("\"", text, "\" is not an integer in range");
  }
  *out = v;
  return Ok{};
}
}  // namespace option_text

class OptionList {
 public:
  // The declaration of `*options` bound to it, keys prefixed with `prefix`, defaults read
  // from a default-constructed Options.
  template <typename Options>
  static OptionList of(Options* options, const std::string& prefix = "") {
    OptionList list(prefix);
    options->declareOptions(list);
    Options defaults{};
    OptionList default_list(prefix);
    defaults.declareOptions(default_list);
    for (size_t i = 0; i < list.fields_.size(); ++i) {
      list.fields_[i].default_text = default_list.fields_[i].get();
    }
    return list;
  }

  // ---- Declaring (inside declareOptions) ----
  template <typename Number>
  requires(std::is_arithmetic_v<Number> && !std::is_same_v<Number, bool>) [[nodiscard(
      "give the option its range: .min(), .max(), .positive(), .in() or .any()")]] OptionRange
      add(const std::string& key, Number* field, std::string unit, std::string doc) {
    auto limits = std::make_shared<OptionRange::Limits>();
    OptionField& f = push(key, std::move(unit), std::move(doc));
    f.get = [field] {
      if constexpr (std::is_floating_point_v<Number>) return option_text::ofDouble(*field);
      return std::to_string(*field);
    };
    f.set = [field, limits](const std::string& text) -> Status {
      Number v{};
      if constexpr (std::is_floating_point_v<Number>) {
        double d = 0;
        if (Status s = option_text::parseDouble(text, &d); !s) return s;
        v = static_cast<Number>(d);
      } else if (Status s = option_text::parseInteger(text, &v); !s) {
        return s;
      }
      if (Status s = OptionRange(limits).check(static_cast<double>(v)); !s) return s;
      *field = v;
      return Ok{};
    };
    f.check = [field, limits] { return OptionRange(limits).check(static_cast<double>(*field)); };
    f.range = limits;
    return OptionRange(limits);
  }
  void add(const std::string& key, bool* field, std::string doc);
  void add(const std::string& key, std::string* field, std::string unit, std::string doc);
  // One of a fixed set of names.
  template <typename Enum>
  void choice(const std::string& key, Enum* field, std::vector<std::pair<std::string, Enum>> names,
              std::string doc) {
    OptionField& f = push(key, "", std::move(doc));
    for (const auto& [name, value] : names) {
      f.allowed += (f.allowed.empty() ? "" : " | ") + name;
    }
    auto table = std::make_shared<std::vector<std::pair<std::string, Enum>>>(std::move(names));
    f.get = [field, table]() -> std::string {
      for (const auto& [name, value] : *table) {
        if (value == *field) return name;
      }
      return "?";
    };
    const std::string allowed = f.allowed;
    f.set = [field, table, allowed](const std::string& text) -> Status {
      for (const auto& [name, value] : *table) {
        if (name == text) {
          *field = value;
          return Ok{};
        }
      }
      return makeError("\"", text, "\" is not one of ", allowed);
    };
    f.check = [get = f.get, allowed]() -> Status {
      if (get() == "?") return makeError("the value is not one of ", allowed);
      return Ok{};
    };
  }
  // A value with a text form of its own (a robust kernel "dcs:20"): `parse` turns text into
  // a value or says why not, `print` gives text that `parse` reads back.
  template <typename T>
  void custom(const std::string& key, T* field,
              std::function<Expected<T>(const std::string&)> parse,
              std::function<std::string(const T&)> print, std::string allowed, std::string doc) {
    OptionField& f = push(key, "", std::move(doc));
    f.allowed = std::move(allowed);
    f.get = [field, print] { return print(*field); };
    f.set = [field, parse](const std::string& text) -> Status {
      Expected<T> v = parse(text);
      if (!v) return Error{v.error()};
      *field = *v;
      return Ok{};
    };
    f.check = [] { return Status(Ok{}); };
  }
  // The options of a member struct, keys prefixed with `prefix` ("tracker.").
  template <typename Sub>
  void nest(const std::string& prefix, Sub* sub) {
    const std::string outer = prefix_;
    prefix_ += prefix;
    sub->declareOptions(*this);
    prefix_ = outer;
  }
  // ... for a struct whose declaration is a function `declare(OptionList&, Sub*)`.
  template <typename Sub, typename Declare>
  void nest(const std::string& prefix, Sub* sub, Declare declare) {
    const std::string outer = prefix_;
    prefix_ += prefix;
    declare(*this, sub);
    prefix_ = outer;
  }

  // ---- Using ----
  // Appends the fields of `other` (one program's options spread over several structs). A
  // key already in the list stays with its first struct (two structs holding the same
  // sub-struct: the IMU's sample gate in the attitude filter and the elevator tracker).
  void append(OptionList other);
  const std::vector<OptionField>& fields() const { return fields_; }
  const OptionField* find(const std::string& key) const;

  // Sets one option from its text. Errors: `unknown option "k"`, or
  // `option k: "x" is outside [0, 3]` (naming the option and the allowed values).
  Status set(const std::string& key, const std::string& text);
  // "key=value" (a --set argument).
  Status assign(const std::string& assignment);
  // The key an assignment sets ("key=value", the key trimmed); empty without '='.
  static std::string keyOf(const std::string& assignment);
  // Every `key = value` of a config file; every key must be declared. Errors name file:line.
  Status loadFile(const std::filesystem::path& path);
  // Every entry of an already-read file (its origin names file:line).
  Status load(const KeyValueFile& file);
  // Every field against its declared range (values set in code, not through set()).
  Status checkRanges() const;

  // "key = value  # unit" lines, readable back by loadFile().
  std::string print() const;
  // (key, value) of each option whose value is not its default, in declaration order.
  std::vector<std::pair<std::string, std::string>> changed() const;
  // One line per option: key, default, unit, allowed values and doc, aligned.
  std::string help() const;
  // The same as a Markdown table.
  std::string markdown() const;

 private:
  explicit OptionList(std::string prefix) : prefix_(std::move(prefix)) {}
  OptionField& push(const std::string& key, std::string unit, std::string doc);

  std::string prefix_;
  std::vector<OptionField> fields_;

 public:
  OptionList() = default;
};

// Checks every field of `options` against its declared range (for validate()).
template <typename Options>
Status checkOptionRanges(const Options& options, const std::string& prefix = "") {
  Options copy = options;
  return OptionList::of(&copy, prefix).checkRanges();
}

// ---- Shorthands over OptionList, for code that holds its options in several structs ----

// The options of several structs in one list (one program's settings: imu-proc's filter,
// heading and process options).
template <typename... Options>
OptionList optionListOf(Options*... options) {
  OptionList list;
  (list.append(OptionList::of(options)), ...);
  return list;
}

// The values of `options` as config lines (what --print-config prints).
template <typename Options>
std::string describeFields(const Options& options) {
  Options copy = options;
  return OptionList::of(&copy).print();
}

// "key=value" (a --set argument) into the first of `options` that declares the key.
template <typename... Options>
Status setFieldFromAssignment(const std::string& assignment, Options*... options) {
  return optionListOf(options...).assign(assignment);
}
template <typename Options>
Status setFieldFromAssignment(Options* options, const std::string& assignment) {
  return OptionList::of(options).assign(assignment);
}

// Reads a config file (--config) into `options`: every key must belong to one of them.
template <typename... Options>
Status loadFields(const std::filesystem::path& file, Options*... options) {
  return optionListOf(options...).loadFile(file);
}

}  // namespace evermap
