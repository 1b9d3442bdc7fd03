#pragma once
// Whether the n numbers at v are all finite (a message's fixed-size arrays: a covariance, a
// transform).

#include <cmath>

namespace evermap {

inline bool allFinite(const double* v, int n) {
  for (int i = 0; i < n; ++i) {
    if (!std::isfinite(v[i])) return false;
  }
  return true;
}

}  // namespace evermap
