#include "core/common/option_fields.h"

#include <algorithm>
#include <charconv>
#include <cstdio>
#include <cstdlib>

#include "core/common/key_value_file.h"

namespace evermap {
namespace {

std::string limitText(double v) { return option_text::ofDouble(v); }

// Markdown table cells hold no '|'.
std::string cell(std::string s) {
  for (size_t i = s.find('|'); i != std::string::npos; i = s.find('|', i + 2)) {
    s.replace(i, 1, "\\|");
  }
  return s.empty() ? " " : s;
}

}  // namespace

namespace option_text {

std::string ofDouble(double v) {
  // Whole numbers as such ("1000000", not "1e+06"), else the shortest exact text.
  if (std::isfinite(v) && v == std::floor(v) && std::abs(v) < 1e15) {
    return std::to_string(static_cast<long long>(v));
  }
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

Status parseDouble(const std::string& text, double* out) {
  double d = 0;
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, d);
  if (text.empty() || ec != std::errc() || ptr != end) {
    return makeError("\"", text, "\" is not a number");
  }
  if (!std::isfinite(d)) return makeError("\"", text, "\" is not a finite number");
  *out = d;
  return Ok{};
}

Status parseBool(const std::string& text, bool* out) {
  if (text == "true" || text == "1" || text == "yes" || text == "on") {
    *out = true;
  } else if (text == "false" || text == "0" || text == "no" || text == "off") {
    *out = false;
  } else {
    return makeError("\"", text, "\" is not true or false");
  }
  return Ok{};
}

}  // namespace option_text

OptionRange& OptionRange::min(double lo) {
  limits_->lo = lo;
  limits_->lo_open = false;
  return *this;
}
OptionRange& OptionRange::above(double lo) {
  limits_->lo = lo;
  limits_->lo_open = true;
  return *this;
}
OptionRange& OptionRange::max(double hi) {
  limits_->hi = hi;
  limits_->hi_open = false;
  return *this;
}
OptionRange& OptionRange::below(double hi) {
  limits_->hi = hi;
  limits_->hi_open = true;
  return *this;
}

bool OptionRange::contains(double v) const {
  const Limits& l = *limits_;
  if (!std::isfinite(v)) return false;
  const bool lo_ok = l.lo_open ? v > l.lo : v >= l.lo;
  const bool hi_ok = l.hi_open ? v < l.hi : v <= l.hi;
  return lo_ok && hi_ok;
}

std::string OptionRange::text() const {
  const Limits& l = *limits_;
  const bool has_lo = std::isfinite(l.lo);
  const bool has_hi = std::isfinite(l.hi);
  if (!has_lo && !has_hi) return "any";
  if (!has_hi) return (l.lo_open ? "> " : ">= ") + limitText(l.lo);
  if (!has_lo) return (l.hi_open ? "< " : "<= ") + limitText(l.hi);
  return (l.lo_open ? "(" : "[") + limitText(l.lo) + ", " + limitText(l.hi) +
         (l.hi_open ? ")" : "]");
}

Status OptionRange::check(double v) const {
  if (contains(v)) return Ok{};
  return makeError(option_text::ofDouble(v), " is outside ", text());
}

std::string OptionField::allowedText() const { return range ? OptionRange(range).text() : allowed; }

OptionField& OptionList::push(const std::string& key, std::string unit, std::string doc) {
  const std::string full = prefix_ + key;
  if (find(full)) {
    std::fprintf(stderr, "OptionList: option %s declared twice\n", full.c_str());
    std::abort();
  }
  OptionField f;
  f.key = full;
  f.unit = std::move(unit);
  f.doc = std::move(doc);
  fields_.push_back(std::move(f));
  return fields_.back();
}

void OptionList::add(const std::string& key, bool* field, std::string doc) {
  OptionField& f = push(key, "", std::move(doc));
  f.allowed = "true | false";
  f.get = [field] { return std::string(*field ? "true" : "false"); };
  f.set = [field](const std::string& text) { return option_text::parseBool(text, field); };
  f.check = [] { return Status(Ok{}); };
}

void OptionList::add(const std::string& key, std::string* field, std::string unit,
                     std::string doc) {
  OptionField& f = push(key, std::move(unit), std::move(doc));
  f.allowed = "text";
  f.get = [field] { return *field; };
  f.set = [field](const std::string& text) -> Status {
    *field = text;
    return Ok{};
  };
  f.check = [] { return Status(Ok{}); };
}

void OptionList::append(OptionList other) {
  for (OptionField& f : other.fields_) {
    if (!find(f.key)) fields_.push_back(std::move(f));
  }
}

const OptionField* OptionList::find(const std::string& key) const {
  for (const OptionField& f : fields_) {
    if (f.key == key) return &f;
  }
  return nullptr;
}

Status OptionList::set(const std::string& key, const std::string& text) {
  const OptionField* f = find(key);
  if (!f) return makeError("unknown option \"", key, "\"");
  if (Status s = f->set(trimmed(text)); !s) {
    return makeError("option ", key, ": ", s.error().message);
  }
  return Ok{};
}

std::string OptionList::keyOf(const std::string& assignment) {
  const auto eq = assignment.find('=');
  return eq == std::string::npos ? std::string() : trimmed(assignment.substr(0, eq));
}

Status OptionList::assign(const std::string& assignment) {
  const auto eq = assignment.find('=');
  if (eq == std::string::npos) return makeError("expected key=value, got \"", assignment, "\"");
  return set(keyOf(assignment), assignment.substr(eq + 1));
}

Status OptionList::loadFile(const std::filesystem::path& path) {
  Expected<KeyValueFile> file = KeyValueFile::load(path);
  if (!file) return Error{file.error()};
  return load(*file);
}

Status OptionList::load(const KeyValueFile& file) {
  for (const KeyValueFile::Entry& e : file.entries()) {
    if (Status s = set(e.key, e.value); !s) return makeError(e.origin, ": ", s.error().message);
  }
  return Ok{};
}

Status OptionList::checkRanges() const {
  for (const OptionField& f : fields_) {
    if (Status s = f.check(); !s) return makeError("option ", f.key, ": ", s.error().message);
  }
  return Ok{};
}

std::string OptionList::print() const {
  std::string out;
  for (const OptionField& f : fields_) {
    const std::string value = f.get();
    // An empty value is no `key = value` line (config files refuse it): the default stays.
    std::string line = (value.empty() ? "# " : "") + f.key + " = " + value;
    if (!f.unit.empty()) line += "  # " + f.unit;
    out += line + "\n";
  }
  return out;
}

std::vector<std::pair<std::string, std::string>> OptionList::changed() const {
  std::vector<std::pair<std::string, std::string>> out;
  for (const OptionField& f : fields_) {
    std::string value = f.get();
    if (value != f.default_text) out.emplace_back(f.key, std::move(value));
  }
  return out;
}

std::string OptionList::help() const {
  std::vector<std::vector<std::string>> rows;
  for (const OptionField& f : fields_) {
    rows.push_back(
        {f.key, f.default_text + (f.unit.empty() ? "" : " " + f.unit), f.allowedText(), f.doc});
  }
  size_t width[3] = {0, 0, 0};
  for (const auto& row : rows) {
    for (size_t c = 0; c < 3; ++c) width[c] = std::max(width[c], row[c].size());
  }
  std::string out;
  for (const auto& row : rows) {
    std::string line = "  ";
    for (size_t c = 0; c < 3; ++c) line += row[c] + std::string(width[c] - row[c].size() + 2, ' ');
    out += line + row[3] + "\n";
  }
  return out;
}

std::string OptionList::markdown() const {
  std::string out =
      "| option | default | unit | allowed | meaning |\n"
      "|---|---|---|---|---|\n";
  for (const OptionField& f : fields_) {
    out += "| `" + f.key + "` | " + cell(f.default_text) + " | " + cell(f.unit) + " | " +
           cell(f.allowedText()) + " | " + cell(f.doc) + " |\n";
  }
  return out;
}

}  // namespace evermap
