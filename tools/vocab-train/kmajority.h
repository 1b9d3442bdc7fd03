#pragma once
// k-majority clustering of binary descriptors (Grana, Borghesani, Manfredi & Cucchiara,
// "A fast approach for integrating ORB descriptors in the bag of words model", SPIE 2013):
// Lloyd's iteration with the Hamming distance, where a cluster's centre is the bitwise
// majority of its members (the binary counterpart of the mean; it minimises the sum of
// Hamming distances to the members bit by bit, so it is a k-medians step). Seeding is
// k-means++ (Arthur & Vassilvitskii, SODA 2007): each next seed is drawn with probability
// proportional to the squared Hamming distance to the nearest seed so far.
//
// Deterministic: the same input and seed give the same centres on every platform (the random
// numbers come from SplitMix64 below, not from <random>'s distributions).

#include <cstdint>
#include <span>
#include <vector>

#include "core/bow/descriptor.h"

namespace evermap::bow {

// SplitMix64 (Steele, Lea & Flood 2014): small, fast, and specified bit for bit.
class SplitMix64 {
 public:
  explicit SplitMix64(uint64_t seed) : state_(seed) {}
  uint64_t next() {
    uint64_t z = (state_ += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
  }
  // Uniform in [0, 1) with 53 random bits.
  double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }
  // Uniform in [0, n), n > 0.
  uint64_t below(uint64_t n) { return static_cast<uint64_t>(uniform() * static_cast<double>(n)); }

 private:
  uint64_t state_;
};

struct KMajorityResult {
  std::vector<Descriptor> centres;             // at most k; clusters that emptied are dropped
  std::vector<std::vector<uint32_t>> members;  // per centre, entries of `members` (input ids)
  int iterations = 0;                          // Lloyd iterations run
  bool converged = false;                      // assignments stopped changing
};

// Clusters all[members[i]] into at most k groups. Fewer than k distinct descriptors give one
// cluster per distinct descriptor. A bit of a centre is 1 when at least half of the members
// have it (ties go to 1, as in DBoW2). Preconditions: k >= 1, max_iterations >= 1.
KMajorityResult kMajority(std::span<const Descriptor> all, std::span<const uint32_t> members, int k,
                          int max_iterations, SplitMix64& rng);

// Bitwise majority of all[members[i]] (ties to 1). Precondition: members not empty.
Descriptor bitwiseMajority(std::span<const Descriptor> all, std::span<const uint32_t> members);

}  // namespace evermap::bow
