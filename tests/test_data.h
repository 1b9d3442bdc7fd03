#pragma once
// Finding the shared real data from tests: $EVERMAP_DATA, else ../shared/data beside the
// project. A test that needs data skips when it is absent, except under CI (CI=true),
// where the absence is a failure.

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <string>

namespace evermap::testing {

inline std::filesystem::path dataRoot() {
  if (const char* env = std::getenv("EVERMAP_DATA"); env && *env) return env;
  return EVERMAP_DATA_DEFAULT;
}

inline bool underCi() {
  const char* ci = std::getenv("CI");
  return ci && std::string(ci) == "true";
}

// The folder of one data set, e.g. dataDir("euroc-v101-micro"), or empty when missing.
inline std::filesystem::path dataDir(const std::string& name) {
  const auto p = dataRoot() / name;
  return std::filesystem::exists(p) ? p : std::filesystem::path();
}

}  // namespace evermap::testing

// Use at the top of a test body: skips (or fails under CI) when the data set is missing.
#define EVERMAP_REQUIRE_DATA(var, name)                                                          \
  const std::filesystem::path var = ::evermap::testing::dataDir(name);                           \
  if (var.empty()) {                                                                             \
    if (::evermap::testing::underCi()) {                                                         \
      FAIL() << "data set " << name << " not found under " << ::evermap::testing::dataRoot()     \
             << " (set EVERMAP_DATA)";                                                           \
    }                                                                                            \
    GTEST_SKIP() << "data set " << name << " not found under " << ::evermap::testing::dataRoot() \
                 << " (set EVERMAP_DATA)";                                                       \
  }
