#pragma once
// Plain `key = value` configuration text, one assignment per line, `#` starts a comment.
// Every problem is reported in one line naming the file and line ("sim.conf:12: ..."), so a
// wrong setting is found without reading code. Typed reading goes through OptionList
// (core/common/option_fields.h), which also refuses keys no option declares.

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "core/common/expected.h"

namespace evermap {

// `s` without its leading and trailing blanks (space, tab, CR, LF).
std::string trimmed(const std::string& s);

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

}  // namespace evermap
