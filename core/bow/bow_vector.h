#pragma once
// The two outputs of Vocabulary::transform (Gálvez-López & Tardós, "Bags of binary words for
// fast place recognition in image sequences", T-RO 2012 — DBoW2):
//   BowVector     — the image as weighted words (tf-idf), L1-normalised: the weights sum to 1.
//                   The "inverted index" of a place database is built from these.
//   FeatureVector — the "direct index": for every vocabulary node at a chosen depth, the
//                   indices of the image's features whose word lies below it. Features of
//                   two images are only compared within the same node (guided matching).

#include <cstdint>
#include <vector>

namespace evermap::bow {

struct WordWeight {
  uint32_t word = 0;
  float weight = 0.0f;
  friend bool operator==(const WordWeight&, const WordWeight&) = default;
};

// Sorted by word, one entry per word, weights > 0 summing to 1 (or empty: no feature fell on a
// word of non-zero weight).
using BowVector = std::vector<WordWeight>;

struct NodeFeatures {
  uint32_t node = 0;               // vocabulary node index
  std::vector<uint32_t> features;  // indices into the image's descriptors, increasing
  friend bool operator==(const NodeFeatures&, const NodeFeatures&) = default;
};
// Sorted by node.
using FeatureVector = std::vector<NodeFeatures>;

// DBoW2's normalised L1 score of two L1-normalised vectors:
//   s(a, b) = 1 - 0.5 * || a - b ||_1,  in [0, 1]  (T-RO 2012, eq. 2).
// For non-negative weights summing to 1 this equals sum over common words of min(a_w, b_w),
// which is how it is computed (only words present in both vectors contribute).
double l1Score(const BowVector& a, const BowVector& b);

// True when `v` is sorted by word with unique words and finite weights > 0. (The sum is not
// checked: a vector may come from a vocabulary whose words were all of zero weight.)
bool isWellFormed(const BowVector& v);

}  // namespace evermap::bow
