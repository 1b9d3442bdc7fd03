#include "core/bow/bow_vector.h"

#include <algorithm>
#include <cmath>

namespace evermap::bow {

double l1Score(const BowVector& a, const BowVector& b) {
  double s = 0.0;
  auto ia = a.begin();
  auto ib = b.begin();
  while (ia != a.end() && ib != b.end()) {
    if (ia->word < ib->word) {
      ++ia;
    } else if (ib->word < ia->word) {
      ++ib;
    } else {
      // |a| + |b| - |a - b| = 2 min(a, b) for non-negative weights.
      s += std::min(ia->weight, ib->weight);
      ++ia;
      ++ib;
    }
  }
  return s;
}

bool isWellFormed(const BowVector& v) {
  for (size_t i = 0; i < v.size(); ++i) {
    if (!std::isfinite(v[i].weight) || v[i].weight <= 0.0f) return false;
    if (i > 0 && v[i - 1].word >= v[i].word) return false;
  }
  return true;
}

}  // namespace evermap::bow
