#pragma once
// Brute-force matching of ORB descriptors by Hamming distance, with the mutual (cross) check:
// a pair (i, j) is kept when j is the nearest of i among b and i the nearest of j among a,
// the distance is at most max_distance, and (optionally) the nearest is clearly nearer than
// the second nearest (Lowe's ratio test, IJCV 2004, section 7.1, applied to Hamming
// distances).

#include <utility>
#include <vector>

#include "core/common/expected.h"
#include "core/features/orb_descriptor.h"

namespace evermap {
class OptionList;  // core/common/option_fields.h
}  // namespace evermap

namespace evermap::core {

struct DescriptorMatchOptions {
  int max_distance = 80;  // bits of 256
  bool mutual = true;
  // Keep i -> j only if d(best) < ratio * d(second best); 1 disables the test.
  double ratio = 0.9;

  Status validate() const;
  void declareOptions(OptionList& o);
};

// Matches (index in a, index in b), in increasing order of the index in a.
std::vector<std::pair<int, int>> matchDescriptors(const std::vector<OrbDescriptor>& a,
                                                  const std::vector<OrbDescriptor>& b,
                                                  const DescriptorMatchOptions& options);

}  // namespace evermap::core
