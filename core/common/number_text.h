#pragma once
// How evermap writes a double into a message: the shortest of %g's forms with `digits`
// significant digits ("1", "0.25", "1.5e-07"), where std::to_string would print "1.000000"
// and "0.000000".

#include <cstdio>
#include <string>

namespace evermap {

inline std::string numberText(double v, int digits = 6) {
  char buf[40];
  std::snprintf(buf, sizeof(buf), "%.*g", digits, v);
  return buf;
}

}  // namespace evermap
