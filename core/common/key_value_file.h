#pragma once
// Plain `key = value` configuration text, one assignment per line, `#` starts a comment.
// Every problem is reported in one line naming the file and line ("sim.conf:12: ..."), so a
// wrong setting is found without reading code. Typed reading goes through KeyValueReader,
// which also reports keys that nothing read (a misspelt key is an error, not a silent
// default).

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "core/common/expected.h"

namespace evermap {

class KeyValueFile {
 public:
  struct Entry {
    std::string key;
    std::string value;
    std::string origin;  // "file.conf:12" or "--set"
  };

  static Expected<KeyValueFile> load(const std::filesystem::path& path);
  // load(), then setAll(overrides, option): a program's --config FILE with its --set list.
  static Expected<KeyValueFile> load(const std::filesystem::path& path,
                                     const std::vector<std::string>& overrides,
                                     const std::string& option);
  // `name` is used in messages in place of a file name.
  static Expected<KeyValueFile> parse(const std::string& text, const std::string& name);

  // Adds or replaces one `key = value` assignment (command-line overrides); `origin` names it.
  Status set(const std::string& assignment, const std::string& origin);
  // set() for each of a program's repeated `option key=value` arguments, in order; the
  // origin of each is "option key=value". Stops at the first bad one.
  Status setAll(const std::vector<std::string>& assignments, const std::string& option);

  // Moves the assignments whose key starts with `prefix` out of this file into a file of
  // their own (same name and folder, keys unchanged): one file holds the settings of two
  // parts of a program, each read and checked for unknown keys on its own ("mapper.map_gate"
  // beside the simulator's keys).
  KeyValueFile extract(const std::string& prefix);

  const Entry* find(const std::string& key) const;
  const std::vector<Entry>& entries() const { return entries_; }
  const std::string& name() const { return name_; }
  // The folder the file was read from (relative paths in values are resolved against it).
  const std::filesystem::path& folder() const { return folder_; }

 private:
  std::string name_;
  std::filesystem::path folder_;
  std::vector<Entry> entries_;
};

// Reads typed values out of a KeyValueFile. A missing key leaves the target untouched (the
// default of the Options struct stays). The first error is kept and returned by finish().
class KeyValueReader {
 public:
  explicit KeyValueReader(const KeyValueFile& file);

  void read(const std::string& key, double* out);
  void read(const std::string& key, int* out);
  void read(const std::string& key, int64_t* out);
  void read(const std::string& key, uint64_t* out);
  void read(const std::string& key, bool* out);
  void read(const std::string& key, std::string* out);

  // "file.conf:12" for a key that was read from the file, else "file.conf (default value)".
  std::string where(const std::string& key) const;
  // The first error, else an error for the first key no read() asked for. Keys starting with
  // one of `ignored_prefixes` are accepted unread.
  Status finish(const std::vector<std::string>& ignored_prefixes = {}) const;

 private:
  template <typename T>
  void readNumber(const std::string& key, T* out, const char* what);
  const KeyValueFile::Entry* use(const std::string& key);

  const KeyValueFile& file_;
  std::vector<bool> used_;
  std::string first_error_;
};

}  // namespace evermap
