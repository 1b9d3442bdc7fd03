#pragma once
// Matching the features of two images through the vocabulary's direct index (DBoW2's
// "FeatureVector"): a feature of image A is only compared with the features of image B that
// fell under the same vocabulary node at the chosen depth. This turns an n x m brute-force
// search into many small ones, and the node acts as a coarse descriptor-space prior.

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "core/bow/bow_vector.h"
#include "core/bow/descriptor.h"

namespace evermap::bow {

struct GuidedMatchOptions {
  // Largest Hamming distance of an accepted match, bits (of 256).
  int max_distance = 64;
  // Lowe's ratio test within the node: best < ratio * second best; 1 disables it.
  double ratio = 0.8;
  // Keep a match only if each feature is the other's best within the node.
  bool mutual = true;

  std::string validate() const;  // empty when valid
};

struct DescriptorMatch {
  uint32_t a = 0;  // feature index in image A
  uint32_t b = 0;  // feature index in image B
  int distance = 0;
};

// `direct_a`/`direct_b` must come from the same vocabulary at the same depth.
std::vector<DescriptorMatch> matchGuided(const FeatureVector& direct_a,
                                         std::span<const Descriptor> a,
                                         const FeatureVector& direct_b,
                                         std::span<const Descriptor> b,
                                         const GuidedMatchOptions& options);

}  // namespace evermap::bow
