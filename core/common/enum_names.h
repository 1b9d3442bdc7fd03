#pragma once
// An enum's names, one table per enum, from which its toString() and its parser come (the
// evaluation's alignment modes, trajectory formats and plot planes; the solver's methods,
// terminations, graph formats and outlier modes).

#include <array>
#include <cstddef>
#include <string>
#include <string_view>
#include <utility>

#include "core/common/expected.h"

namespace evermap {

template <class Enum, size_t N>
using EnumNames = std::array<std::pair<Enum, const char*>, N>;

// The name of `value`; "?" for a value the table lacks.
template <class Enum, size_t N>
const char* nameOf(const EnumNames<Enum, N>& names, Enum value) {
  for (const auto& [v, name] : names) {
    if (v == value) return name;
  }
  return "?";
}

// The value called `name`; else the error `unknown WHAT "name" (expected a, b or c)`, the
// names in the table's order.
template <class Enum, size_t N>
Expected<Enum> parseName(const EnumNames<Enum, N>& names, std::string_view name, const char* what) {
  std::string expected;
  for (size_t i = 0; i < N; ++i) {
    if (name == names[i].second) return names[i].first;
    expected += (i == 0 ? "" : i + 1 == N ? " or " : ", ") + std::string(names[i].second);
  }
  return makeError("unknown ", what, " \"", std::string(name), "\" (expected ", expected, ")");
}

}  // namespace evermap
