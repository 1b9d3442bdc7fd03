#include "tools/place-eval/guided_matching.h"

#include <algorithm>
#include <limits>

namespace evermap::bow {

std::string GuidedMatchOptions::validate() const {
  if (max_distance < 0 || max_distance > kDescriptorBits) return "max_distance must be in [0, 256]";
  if (!(ratio > 0.0 && ratio <= 1.0)) return "ratio must be in (0, 1]";
  return {};
}

namespace {

struct Best {
  uint32_t index = 0;
  int distance = std::numeric_limits<int>::max();
  int second = std::numeric_limits<int>::max();
};

// For each feature of `from`, its best and second-best distance among `to`.
EVERMAP_POPCNT_CLONES
std::vector<Best> bestIn(const std::vector<uint32_t>& from, std::span<const Descriptor> df,
                         const std::vector<uint32_t>& to, std::span<const Descriptor> dt) {
  std::vector<Best> out(from.size());
  for (size_t i = 0; i < from.size(); ++i) {
    Best& best = out[i];
    for (uint32_t j : to) {
      const int d = hammingDistance(df[from[i]], dt[j]);
      if (d < best.distance) {
        best.second = best.distance;
        best.distance = d;
        best.index = j;
      } else if (d < best.second) {
        best.second = d;
      }
    }
  }
  return out;
}

}  // namespace

std::vector<DescriptorMatch> matchGuided(const FeatureVector& direct_a,
                                         std::span<const Descriptor> a,
                                         const FeatureVector& direct_b,
                                         std::span<const Descriptor> b,
                                         const GuidedMatchOptions& options) {
  std::vector<DescriptorMatch> out;
  auto ia = direct_a.begin();
  auto ib = direct_b.begin();
  while (ia != direct_a.end() && ib != direct_b.end()) {
    if (ia->node < ib->node) {
      ++ia;
      continue;
    }
    if (ib->node < ia->node) {
      ++ib;
      continue;
    }
    const std::vector<Best> ab = bestIn(ia->features, a, ib->features, b);
    std::vector<Best> ba;
    if (options.mutual) ba = bestIn(ib->features, b, ia->features, a);
    for (size_t i = 0; i < ab.size(); ++i) {
      const Best& m = ab[i];
      if (m.distance > options.max_distance) continue;
      // Ratio test; a lone candidate (no second) passes.
      if (options.ratio < 1.0 && m.second != std::numeric_limits<int>::max() &&
          static_cast<double>(m.distance) >= options.ratio * m.second) {
        continue;
      }
      if (options.mutual) {
        // Position of m.index in ib->features (they are increasing).
        const auto& fb = ib->features;
        const size_t pos =
            static_cast<size_t>(std::lower_bound(fb.begin(), fb.end(), m.index) - fb.begin());
        if (ba[pos].index != ia->features[i]) continue;
      }
      out.push_back({ia->features[i], m.index, m.distance});
    }
    ++ia;
    ++ib;
  }
  return out;
}

}  // namespace evermap::bow
