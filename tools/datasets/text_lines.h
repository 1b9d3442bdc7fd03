#pragma once
// Lines of the data sets' text files (CSV, TUM trajectories, associations).

#include <cctype>
#include <filesystem>
#include <fstream>
#include <string>

#include "core/common/expected.h"

namespace evermap::datasets {

// A line with nothing but white space, or whose first other character starts a comment (#).
inline bool isCommentOrBlank(const std::string& line) {
  for (char c : line) {
    if (c == '#') return true;
    if (!std::isspace(static_cast<unsigned char>(c))) return false;
  }
  return true;
}

// Calls row(line, n) for every line of `file` that is not blank or a comment, n its number
// (from 1); stops at the first error `row` returns. Errors: `file` cannot be opened or read.
template <typename Row>
Status forEachDataLine(const std::filesystem::path& file, Row row) {
  std::ifstream in(file);
  if (!in) return makeError(file.string(), ": cannot open");
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    if (isCommentOrBlank(line)) continue;
    if (Status s = row(line, n); !s) return s;
  }
  if (in.bad()) return makeError(file.string(), ": read error");
  return Ok{};
}

}  // namespace evermap::datasets
