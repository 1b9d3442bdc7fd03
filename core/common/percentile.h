#pragma once
// The one percentile of the project's reports (timing columns, disparity statistics): the
// nearest rank, the element of the sorted values at round(q (n - 1)), so q = 0 is the minimum,
// q = 1 the maximum and q = 0.5 the median of an odd count.

#include <vector>

namespace evermap {

// Contract: 0 <= q <= 1. An empty `values` gives 0.
double percentile(std::vector<double> values, double q);

}  // namespace evermap
