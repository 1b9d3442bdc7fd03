#pragma once
// Lines of the data sets' text files (CSV, TUM trajectories, associations).

#include <cctype>
#include <string>

namespace evermap::datasets {

// A line with nothing but white space, or whose first other character starts a comment (#).
inline bool isCommentOrBlank(const std::string& line) {
  for (char c : line) {
    if (c == '#') return true;
    if (!std::isspace(static_cast<unsigned char>(c))) return false;
  }
  return true;
}

}  // namespace evermap::datasets
