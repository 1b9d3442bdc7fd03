#pragma once
// Printing and setting the fields of an Options struct by name (STYLE.md: options are
// "loadable from a config file and printable"). An Options struct lists its fields once:
//
//   template <typename F> void forEachField(F&& f) {
//     f("max_gap_s", max_gap_s, "s");   // name, reference, unit
//   }
//
// and gets `describeFields(o)` ("name = value  # unit" lines) and `setField(o, key, value)`.
// Config files hold the same "name = value" lines; '#' starts a comment.

#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "core/common/expected.h"

namespace evermap {

namespace option_fields_detail {
inline std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\r\n");
  if (b == std::string::npos) return {};
  const auto e = s.find_last_not_of(" \t\r\n");
  return s.substr(b, e - b + 1);
}
inline std::string format(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.9g", v);
  return buf;
}
}  // namespace option_fields_detail

template <typename Options>
std::string describeFields(const Options& options) {
  Options copy = options;
  std::string out;
  copy.forEachField([&out](const char* name, auto& value, const char* unit) {
    out += name;
    out += " = ";
    out += option_fields_detail::format(static_cast<double>(value));
    if (unit && *unit) {
      out += "  # ";
      out += unit;
    }
    out += '\n';
  });
  return out;
}

// Sets the field called key from its text; an unknown key or a value that is not a number of
// the field's type is an error naming both.
template <typename Options>
Status setField(Options* options, const std::string& key, const std::string& value) {
  bool found = false;
  bool parsed = false;
  const std::string v = option_fields_detail::trim(value);
  options->forEachField([&](const char* name, auto& field, const char*) {
    if (key != name) return;
    found = true;
    using T = std::decay_t<decltype(field)>;
    if constexpr (std::is_same_v<T, bool>) {
      if (v == "1" || v == "true") {
        field = true;
        parsed = true;
      }
      if (v == "0" || v == "false") {
        field = false;
        parsed = true;
      }
    } else if constexpr (std::is_floating_point_v<T>) {
      // Finite only: "inf" and "nan" parse as numbers but are never a valid setting (a
      // rate of inf, a threshold of nan that every comparison fails).
      try {
        size_t used = 0;
        const double d = std::stod(v, &used);
        if (used == v.size() && std::isfinite(d)) {
          field = static_cast<T>(d);
          parsed = true;
        }
      } catch (...) {
      }
    } else {
      T n{};
      const auto r = std::from_chars(v.data(), v.data() + v.size(), n);
      if (r.ec == std::errc() && r.ptr == v.data() + v.size()) {
        field = n;
        parsed = true;
      }
    }
  });
  if (!found) return makeError("unknown option \"", key, "\"");
  if (!parsed) {
    const bool number =
        v == "inf" || v == "-inf" || v == "nan" || v.find("e999") != std::string::npos;
    return makeError("option ", key, ": bad value \"", v, "\"",
                     number ? " (not a finite number)" : "");
  }
  return Ok{};
}

// Sets `key` in the first of `options` that has a field of that name: one program's settings
// spread over several Options structs (imu-proc's filter, heading and process options). A
// key none of them has is "unknown option"; a bad value is an error naming key and value.
template <typename... Options>
Status setFieldOfAny(const std::string& key, const std::string& value, Options*... options) {
  Status result = makeError("unknown option \"", key, "\"");
  bool done = false;
  auto attempt = [&](auto* o) {
    if (done) return;
    Status st = setField(o, key, value);
    if (st.ok() || st.error().message.rfind("unknown option", 0) != 0) {
      result = std::move(st);
      done = true;
    }
  };
  (attempt(options), ...);
  return result;
}

// Splits "key=value" (as given on a command line, --set) and sets it in the first of
// `options` that has the key.
template <typename... Options>
Status setFieldFromAssignment(const std::string& assignment, Options*... options) {
  const auto eq = assignment.find('=');
  if (eq == std::string::npos) return makeError("expected key=value, got \"", assignment, "\"");
  return setFieldOfAny(option_fields_detail::trim(assignment.substr(0, eq)),
                       assignment.substr(eq + 1), options...);
}
template <typename Options>
Status setFieldFromAssignment(Options* options, const std::string& assignment) {
  return setFieldFromAssignment(assignment, options);
}

// Reads "key = value" lines from a file (--config) into `options`, with exactly the rules of
// --set: every key must belong to one of them (a misspelt key is an error, never a silent
// default) and every number must be finite. Errors name the file and line.
template <typename... Options>
Status loadFields(const std::filesystem::path& file, Options*... options) {
  std::ifstream in(file);
  if (!in) return makeError(file.string(), ": cannot open");
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    const auto hash = line.find('#');
    const std::string body = option_fields_detail::trim(line.substr(0, hash));
    if (body.empty()) continue;
    const auto eq = body.find('=');
    if (eq == std::string::npos) {
      return makeError(file.string(), ":", n, ": expected \"key = value\"");
    }
    const std::string key = option_fields_detail::trim(body.substr(0, eq));
    if (Status st = setFieldOfAny(key, body.substr(eq + 1), options...); !st.ok()) {
      return makeError(file.string(), ":", n, ": ", st.error().message);
    }
  }
  if (in.bad()) return makeError(file.string(), ": read error");
  return Ok{};
}

}  // namespace evermap
