#include "core/common/percentile.h"

#include <algorithm>
#include <cstddef>

namespace evermap {

double percentile(std::vector<double> values, double q) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const size_t last = values.size() - 1;
  return values[std::min(last, static_cast<size_t>(q * static_cast<double>(last) + 0.5))];
}

}  // namespace evermap
