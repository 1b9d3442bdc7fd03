#include "tools/vocab-train/kmajority.h"

#include <array>
#include <cstdio>
#include <cstdlib>
#include <limits>

namespace evermap::bow {

namespace {

using BitCounts = std::array<uint32_t, kDescriptorBits>;

void countBits(const Descriptor& d, BitCounts& counts) {
  for (int byte = 0; byte < kDescriptorBytes; ++byte) {
    const unsigned v = d.bytes[static_cast<size_t>(byte)];
    for (int b = 0; b < 8; ++b) counts[static_cast<size_t>(8 * byte + b)] += (v >> b) & 1u;
  }
}

Descriptor majorityOf(const BitCounts& counts, size_t n) {
  Descriptor d;
  for (int i = 0; i < kDescriptorBits; ++i) {
    if (2 * static_cast<size_t>(counts[static_cast<size_t>(i)]) >= n) d.setBit(i);
  }
  return d;
}

// k-means++ seeds among all[members]; stops early when every member coincides with a seed.
EVERMAP_POPCNT_CLONES
std::vector<Descriptor> seedPlusPlus(std::span<const Descriptor> all,
                                     std::span<const uint32_t> members, int k, SplitMix64& rng) {
  std::vector<Descriptor> seeds;
  const size_t m = members.size();
  seeds.push_back(all[members[rng.below(m)]]);
  std::vector<double> d2(m);
  for (size_t i = 0; i < m; ++i) {
    const double d = hammingDistance(all[members[i]], seeds[0]);
    d2[i] = d * d;
  }
  while (static_cast<int>(seeds.size()) < k) {
    double total = 0.0;
    for (double v : d2) total += v;
    if (total <= 0.0) break;  // fewer distinct descriptors than k
    const double r = rng.uniform() * total;
    double cumulative = 0.0;
    size_t pick = m;
    for (size_t i = 0; i < m; ++i) {
      cumulative += d2[i];
      if (d2[i] > 0.0 && cumulative > r) {
        pick = i;
        break;
      }
    }
    if (pick == m) {  // rounding left r at the very end: take the last eligible member
      for (size_t i = m; i-- > 0;) {
        if (d2[i] > 0.0) {
          pick = i;
          break;
        }
      }
    }
    seeds.push_back(all[members[pick]]);
    for (size_t i = 0; i < m; ++i) {
      const double d = hammingDistance(all[members[i]], seeds.back());
      d2[i] = std::min(d2[i], d * d);
    }
  }
  return seeds;
}

// Assigns each member to its nearest centre (the first on a tie); true if any assignment
// changed.
EVERMAP_POPCNT_CLONES
bool assignToNearest(std::span<const Descriptor> all, std::span<const uint32_t> members,
                     const std::vector<Descriptor>& centres, std::vector<uint32_t>& assignment) {
  bool changed = false;
  for (size_t i = 0; i < members.size(); ++i) {
    const Descriptor& d = all[members[i]];
    uint32_t best = 0;
    int best_distance = hammingDistance(d, centres[0]);
    for (uint32_t j = 1; j < centres.size(); ++j) {
      const int dist = hammingDistance(d, centres[j]);
      if (dist < best_distance) {
        best_distance = dist;
        best = j;
      }
    }
    changed = changed || assignment[i] != best;
    assignment[i] = best;
  }
  return changed;
}

}  // namespace

Descriptor bitwiseMajority(std::span<const Descriptor> all, std::span<const uint32_t> members) {
  if (members.empty()) {
    std::fprintf(stderr, "evermap: bitwiseMajority of an empty set\n");
    std::abort();
  }
  BitCounts counts{};
  for (uint32_t i : members) countBits(all[i], counts);
  return majorityOf(counts, members.size());
}

KMajorityResult kMajority(std::span<const Descriptor> all, std::span<const uint32_t> members, int k,
                          int max_iterations, SplitMix64& rng) {
  if (k < 1 || max_iterations < 1) {
    std::fprintf(stderr, "evermap: kMajority needs k >= 1 and max_iterations >= 1\n");
    std::abort();
  }
  KMajorityResult out;
  if (members.empty()) return out;
  std::vector<Descriptor> centres = seedPlusPlus(all, members, k, rng);
  const size_t c = centres.size();
  std::vector<uint32_t> assignment(members.size(), std::numeric_limits<uint32_t>::max());

  auto assign = [&]() { return assignToNearest(all, members, centres, assignment); };

  std::vector<BitCounts> counts(c);
  std::vector<size_t> sizes(c);
  int it = 0;
  for (; it < max_iterations; ++it) {
    const bool changed = assign();
    if (!changed && it > 0) {
      out.converged = true;
      break;
    }
    for (auto& cnt : counts) cnt.fill(0);
    std::fill(sizes.begin(), sizes.end(), 0);
    for (size_t i = 0; i < members.size(); ++i) {
      countBits(all[members[i]], counts[assignment[i]]);
      ++sizes[assignment[i]];
    }
    // An emptied cluster keeps its centre; it is dropped below if it stays empty.
    for (size_t j = 0; j < c; ++j) {
      if (sizes[j] > 0) centres[j] = majorityOf(counts[j], sizes[j]);
    }
  }
  // Members belong to the nearest of the final centres (unless that is already so).
  if (!out.converged) out.converged = !assign();
  out.iterations = it;

  std::vector<std::vector<uint32_t>> groups(c);
  for (size_t i = 0; i < members.size(); ++i) groups[assignment[i]].push_back(members[i]);
  for (size_t j = 0; j < c; ++j) {
    if (groups[j].empty()) continue;
    out.centres.push_back(centres[j]);
    out.members.push_back(std::move(groups[j]));
  }
  return out;
}

}  // namespace evermap::bow
