#pragma once
// A vocabulary tree over 256-bit binary descriptors (Nistér & Stewénius, CVPR 2006, with the
// binary adaptation of DBoW2: Gálvez-López & Tardós, T-RO 2012).
//
// The tree has branching factor k and at most L levels below the root. Every inner node holds
// a descriptor (the bitwise majority of the training descriptors below it, see kmajority.h);
// the leaves are the words. A descriptor is quantised by descending from the root, at each
// level to the child at the smallest Hamming distance (the first such child on a tie — DBoW2's
// rule, so vocabularies trained by DBoW2/DBoW3 quantise as they did there). Each word carries
// an idf weight, ln(N / n_w) over the N training images of which n_w contain the word; a word
// seen in every training image (or in none) weighs 0 and is left out of bag-of-words vectors.
// Weighting is tf-idf and scoring the normalised L1 score (bow_vector.h); these are the only
// ones evermap implements.
//
// Invariant (checked by create()): node 0 is the root; nodes are stored breadth first, so the
// children of a node are contiguous; every leaf is exactly one word and every word a leaf; word
// ids are 0..W-1; no node has more than k children or lies deeper than L; weights are finite
// and >= 0. A Vocabulary is immutable once made and safe to share between threads.

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "core/bow/bow_vector.h"
#include "core/bow/descriptor.h"
#include "core/common/expected.h"

namespace evermap::bow {

// One node as a file or the trainer describes it; the list may be in any order as long as
// entry 0 is the root and every other entry names its parent's position in the list.
struct NodeSpec {
  int64_t parent = -1;    // position of the parent in the list; -1 for the root only
  Descriptor descriptor;  // ignored for the root
  double weight = 0.0;    // idf of a word; ignored for inner nodes
  int64_t word = -1;      // the word id of a leaf; -1 for an inner node
};

class Vocabulary {
 public:
  static constexpr uint32_t kNoParent = 0xFFFFFFFFu;

  // Checks the invariant above and stores the nodes breadth first (word ids are kept).
  // Errors name `what` (a file name, or "trained vocabulary") and the offending node.
  static Expected<Vocabulary> create(int branching, int levels, std::vector<NodeSpec> nodes,
                                     const std::string& what);

  int branching() const { return branching_; }
  int levels() const { return levels_; }
  size_t numNodes() const { return parent_.size(); }
  size_t numWords() const { return node_of_word_.size(); }
  // FNV-1a 64 over the canonical content (shape, and every node's parent, word, weight and
  // descriptor breadth first): two vocabularies that quantise and weigh alike have the same
  // fingerprint. A place database remembers it, so BoW vectors are never compared across
  // vocabularies.
  uint64_t fingerprint() const { return fingerprint_; }

  // ---- quantisation ----
  uint32_t wordOf(const Descriptor& d) const;
  // L1-normalised tf-idf vector of an image's descriptors.
  BowVector transform(std::span<const Descriptor> descriptors) const;
  // The same, plus the direct index: features grouped by their ancestor node at
  // `direct_index_depth` levels below the root (1..L; a word shallower than that is its own
  // group). Either output may be null.
  void transform(std::span<const Descriptor> descriptors, int direct_index_depth, BowVector* bow,
                 FeatureVector* direct) const;

  // ---- structure (breadth-first node indices; node 0 is the root) ----
  uint32_t parent(uint32_t node) const { return parent_[node]; }
  uint32_t firstChild(uint32_t node) const { return first_child_[node]; }
  uint32_t numChildren(uint32_t node) const { return num_children_[node]; }
  int depth(uint32_t node) const { return depth_[node]; }
  const Descriptor& descriptor(uint32_t node) const { return descriptors_[node]; }
  bool isWord(uint32_t node) const { return word_of_node_[node] >= 0; }
  int64_t wordOfNode(uint32_t node) const { return word_of_node_[node]; }
  uint32_t nodeOfWord(uint32_t word) const { return node_of_word_[word]; }
  double weight(uint32_t word) const { return word_weight_[word]; }
  // Number of leaves at each depth 0..L (a well-trained tree has nearly all at L).
  std::vector<size_t> wordsPerDepth() const;

 private:
  Vocabulary() = default;
  // The word of `d` and the node on its path at `depth` (or the word's node if shallower).
  uint32_t descend(const Descriptor& d, int depth, uint32_t* node_at_depth) const;

  int branching_ = 0;
  int levels_ = 0;
  uint64_t fingerprint_ = 0;
  std::vector<uint32_t> parent_;
  std::vector<uint32_t> first_child_;
  std::vector<uint32_t> num_children_;
  std::vector<uint8_t> depth_;
  std::vector<int64_t> word_of_node_;
  std::vector<uint32_t> node_of_word_;
  std::vector<double> word_weight_;
  std::vector<Descriptor> descriptors_;
};

}  // namespace evermap::bow
