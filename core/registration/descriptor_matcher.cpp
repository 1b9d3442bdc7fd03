#include "core/registration/descriptor_matcher.h"

#include <cstring>
#include <limits>

#include "core/common/option_fields.h"

namespace evermap::core {

namespace {

// Hamming distances from one descriptor to n others: the bulk of brute-force matching.
// Compiled with and without the POPCNT instruction, chosen at load time.
__attribute__((target_clones("popcnt", "default"))) void hammingRow(const OrbDescriptor& a,
                                                                    const OrbDescriptor* b, int n,
                                                                    int* out) {
  uint64_t x[4];
  std::memcpy(x, a.data(), 32);
  for (int j = 0; j < n; ++j) {
    uint64_t y[4];
    std::memcpy(y, b[j].data(), 32);
    out[j] = __builtin_popcountll(x[0] ^ y[0]) + __builtin_popcountll(x[1] ^ y[1]) +
             __builtin_popcountll(x[2] ^ y[2]) + __builtin_popcountll(x[3] ^ y[3]);
  }
}

}  // namespace

void DescriptorMatchOptions::declareOptions(OptionList& o) {
  o.add("max_distance", &max_distance, "bits", "largest Hamming distance of a match (of 256)")
      .in(0, 256);
  o.add("mutual", &mutual, "keep only matches that are each other's best");
  o.add("ratio", &ratio, "", "keep a match only if best < ratio * second best (1: off)")
      .above(0)
      .max(1);
}

Status DescriptorMatchOptions::validate() const { return checkOptionRanges(*this, "matching."); }

std::vector<std::pair<int, int>> matchDescriptors(const std::vector<OrbDescriptor>& a,
                                                  const std::vector<OrbDescriptor>& b,
                                                  const DescriptorMatchOptions& options) {
  constexpr int kNone = -1;
  const int na = static_cast<int>(a.size()), nb = static_cast<int>(b.size());
  std::vector<int> best_a(static_cast<size_t>(na), kNone), dist_a(static_cast<size_t>(na), 257),
      second_a(static_cast<size_t>(na), 257);
  std::vector<int> best_b(static_cast<size_t>(nb), kNone), dist_b(static_cast<size_t>(nb), 257);
  std::vector<int> row(static_cast<size_t>(nb));
  for (int i = 0; i < na; ++i) {
    hammingRow(a[static_cast<size_t>(i)], b.data(), nb, row.data());
    for (int j = 0; j < nb; ++j) {
      const int d = row[static_cast<size_t>(j)];
      if (d < dist_a[static_cast<size_t>(i)]) {
        second_a[static_cast<size_t>(i)] = dist_a[static_cast<size_t>(i)];
        dist_a[static_cast<size_t>(i)] = d;
        best_a[static_cast<size_t>(i)] = j;
      } else if (d < second_a[static_cast<size_t>(i)]) {
        second_a[static_cast<size_t>(i)] = d;
      }
      if (d < dist_b[static_cast<size_t>(j)]) {
        dist_b[static_cast<size_t>(j)] = d;
        best_b[static_cast<size_t>(j)] = i;
      }
    }
  }
  std::vector<std::pair<int, int>> out;
  for (int i = 0; i < na; ++i) {
    const int j = best_a[static_cast<size_t>(i)];
    if (j == kNone) continue;
    const int d = dist_a[static_cast<size_t>(i)];
    if (d > options.max_distance) continue;
    if (options.mutual && best_b[static_cast<size_t>(j)] != i) continue;
    if (options.ratio < 1.0 && second_a[static_cast<size_t>(i)] <= 256 &&
        !(d < options.ratio * second_a[static_cast<size_t>(i)])) {
      continue;
    }
    out.emplace_back(i, j);
  }
  return out;
}

}  // namespace evermap::core
