#include "core/common/key_value_file.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <sstream>

namespace evermap {

std::string trimmed(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\r\n");
  if (b == std::string::npos) return {};
  const auto e = s.find_last_not_of(" \t\r\n");
  return s.substr(b, e - b + 1);
}

namespace {

bool validKey(const std::string& k) {
  if (k.empty()) return false;
  for (char c : k) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                    c == '_' || c == '.' || c == '-';
    if (!ok) return false;
  }
  return true;
}

// Splits "key = value" (comment already removed); an error message on failure.
Expected<std::pair<std::string, std::string>> splitAssignment(const std::string& text) {
  const auto eq = text.find('=');
  if (eq == std::string::npos) return makeError("expected 'key = value', got '", text, "'");
  const std::string key = trimmed(text.substr(0, eq));
  const std::string value = trimmed(text.substr(eq + 1));
  if (!validKey(key)) return makeError("bad key '", key, "' (letters, digits, _ . - only)");
  if (value.empty()) return makeError("key '", key, "' has no value");
  return std::make_pair(key, value);
}

}  // namespace

Expected<KeyValueFile> KeyValueFile::load(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) {
    // A relative path is relative to where the program runs (a deputy's folder): say where.
    std::error_code ec;
    const std::string where =
        path.is_relative() ? " (from " + std::filesystem::current_path(ec).string() + ")" : "";
    return makeError(path.string(), ": cannot open configuration file", where);
  }
  std::ostringstream text;
  text << in.rdbuf();
  auto file = parse(text.str(), path.string());
  if (file) file->folder_ = path.parent_path();
  return file;
}

Expected<KeyValueFile> KeyValueFile::parse(const std::string& text, const std::string& name) {
  KeyValueFile f;
  f.name_ = name;
  std::istringstream in(text);
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    const std::string origin = name + ":" + std::to_string(number);
    if (line.find('\0') != std::string::npos) return makeError(origin, ": binary data in text");
    const std::string body = trimmed(line.substr(0, line.find('#')));
    if (body.empty()) continue;
    auto kv = splitAssignment(body);
    if (!kv) return makeError(origin, ": ", kv.error().message);
    if (const Entry* prev = f.find(kv->first)) {
      return makeError(origin, ": key '", kv->first, "' already set at ", prev->origin);
    }
    f.entries_.push_back(Entry{kv->first, kv->second, origin});
  }
  return f;
}

Status KeyValueFile::set(const std::string& assignment, const std::string& origin) {
  auto kv = splitAssignment(trimmed(assignment));
  if (!kv) return makeError(origin, ": ", kv.error().message);
  for (Entry& e : entries_) {
    if (e.key == kv->first) {
      e.value = kv->second;
      e.origin = origin;
      return Ok{};
    }
  }
  entries_.push_back(Entry{kv->first, kv->second, origin});
  return Ok{};
}

KeyValueFile KeyValueFile::extract(const std::string& prefix) {
  KeyValueFile out;
  out.name_ = name_;
  out.folder_ = folder_;
  std::vector<Entry> kept;
  for (Entry& e : entries_) {
    if (e.key.size() > prefix.size() && e.key.compare(0, prefix.size(), prefix) == 0) {
      out.entries_.push_back(std::move(e));
    } else {
      kept.push_back(std::move(e));
    }
  }
  entries_ = std::move(kept);
  return out;
}

const KeyValueFile::Entry* KeyValueFile::find(const std::string& key) const {
  for (const Entry& e : entries_) {
    if (e.key == key) return &e;
  }
  return nullptr;
}

Expected<KeyValueFile> KeyValueFile::load(const std::filesystem::path& path,
                                          const std::vector<std::string>& overrides,
                                          const std::string& option) {
  auto file = load(path);
  if (!file) return file;
  if (Status s = file->setAll(overrides, option); !s) return s.error();
  return file;
}

Status KeyValueFile::setAll(const std::vector<std::string>& assignments,
                            const std::string& option) {
  for (const std::string& a : assignments) {
    if (Status s = set(a, option + " " + a); !s) return s;
  }
  return Ok{};
}

}  // namespace evermap
