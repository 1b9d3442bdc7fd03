#include "viewer/json_writer.h"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace evermap::viewer {
namespace {
void check(bool ok, const char* what) {
  if (!ok) {
    std::fprintf(stderr, "JsonWriter: %s\n", what);
    std::abort();
  }
}
}  // namespace

void JsonWriter::beforeValue() {
  if (object_.empty()) {
    check(out_.empty(), "a second value at the top level");
    return;
  }
  if (object_.back()) {
    check(after_key_, "a value inside an object without a key");
    after_key_ = false;
    return;
  }
  if (!first_.back()) out_ += ',';
  first_.back() = false;
}

JsonWriter& JsonWriter::open(bool object) {
  beforeValue();
  out_ += object ? '{' : '[';
  object_.push_back(object);
  first_.push_back(true);
  return *this;
}

JsonWriter& JsonWriter::close(bool object) {
  if (object) {
    check(!object_.empty() && object_.back() && !after_key_, "endObject without its object");
  } else {
    check(!object_.empty() && !object_.back(), "endArray without its array");
  }
  out_ += object ? '}' : ']';
  object_.pop_back();
  first_.pop_back();
  return *this;
}

JsonWriter& JsonWriter::beginObject() { return open(true); }

JsonWriter& JsonWriter::endObject() { return close(true); }

JsonWriter& JsonWriter::beginArray() { return open(false); }

JsonWriter& JsonWriter::endArray() { return close(false); }

JsonWriter& JsonWriter::key(std::string_view k) {
  check(!object_.empty() && object_.back() && !after_key_, "a key outside an object");
  if (!first_.back()) out_ += ',';
  first_.back() = false;
  writeString(k);
  out_ += ':';
  after_key_ = true;
  return *this;
}

JsonWriter& JsonWriter::value(std::string_view s) {
  beforeValue();
  writeString(s);
  return *this;
}

void JsonWriter::writeString(std::string_view s) {
  out_ += '"';
  for (const char c : s) {
    const auto u = static_cast<unsigned char>(c);
    switch (c) {
      case '"':
        out_ += "\\\"";
        break;
      case '\\':
        out_ += "\\\\";
        break;
      case '\n':
        out_ += "\\n";
        break;
      case '\r':
        out_ += "\\r";
        break;
      case '\t':
        out_ += "\\t";
        break;
      default:
        if (u >= 0x80) {
          // Text frames must be valid UTF-8 or the browser closes the connection: strings
          // from LCM (a process name, a reason) may hold any byte, so only ASCII passes.
          out_ += '?';
        } else if (u < 0x20 || u == 0x7f) {
          char buf[8];
          std::snprintf(buf, sizeof buf, "\\u%04x", u);
          out_ += buf;
        } else {
          out_ += c;
        }
    }
  }
  out_ += '"';
}

JsonWriter& JsonWriter::value(int64_t v) {
  beforeValue();
  char buf[24];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  out_.append(buf, r.ptr);
  return *this;
}

JsonWriter& JsonWriter::value(bool v) {
  beforeValue();
  out_ += v ? "true" : "false";
  return *this;
}

JsonWriter& JsonWriter::value(double v, int decimals) {
  if (!std::isfinite(v)) return null();
  beforeValue();
  char buf[64];
  // Beyond 1e15 fixed notation is long and meaningless for the page: exponent form.
  const auto r = std::abs(v) < 1e15
                     ? std::to_chars(buf, buf + sizeof buf, v, std::chars_format::fixed, decimals)
                     : std::to_chars(buf, buf + sizeof buf, v, std::chars_format::scientific, 6);
  out_.append(buf, r.ptr);
  return *this;
}

JsonWriter& JsonWriter::null() {
  beforeValue();
  out_ += "null";
  return *this;
}

JsonWriter& JsonWriter::raw(std::string_view json) {
  beforeValue();
  out_ += json;
  return *this;
}

std::string JsonWriter::take() {
  check(object_.empty(), "take() with a container still open");
  std::string s = std::move(out_);
  out_.clear();
  return s;
}

}  // namespace evermap::viewer
