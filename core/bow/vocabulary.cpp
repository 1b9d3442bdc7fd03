#include "core/bow/vocabulary.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <deque>
#include <utility>

#include "core/bow/fnv.h"

namespace evermap::bow {

namespace {
constexpr int kMaxBranching = 4096;
constexpr int kMaxLevels = 32;

using Children = std::vector<std::vector<uint32_t>>;

// The children of every node, in the order of `nodes`; an error when a parent is not another
// node.
Expected<Children> childrenOf(const std::vector<NodeSpec>& nodes, const std::string& what) {
  const size_t n = nodes.size();
  Children children(n);
  for (size_t i = 1; i < n; ++i) {
    const int64_t p = nodes[i].parent;
    if (p < 0 || p >= static_cast<int64_t>(n) || p == static_cast<int64_t>(i)) {
      return makeError(what, ": node ", i, " has parent ", p, ", which is not another node");
    }
    children[static_cast<size_t>(p)].push_back(static_cast<uint32_t>(i));
  }
  return children;
}

// Breadth-first order from the root: children of one node are enqueued together, hence
// contiguous. Errors: more than k children, deeper than L, nodes the root does not reach.
Status breadthFirst(const Children& children, int branching, int levels, const std::string& what,
                    std::vector<uint32_t>* order, std::vector<uint8_t>* depth_old) {
  const size_t n = children.size();
  order->reserve(n);
  order->push_back(0);
  for (size_t head = 0; head < order->size(); ++head) {
    const uint32_t old = (*order)[head];
    if (children[old].size() > static_cast<size_t>(branching)) {
      return makeError(what, ": node ", old, " has ", children[old].size(),
                       " children, more than k = ", branching);
    }
    for (uint32_t c : children[old]) {
      (*depth_old)[c] = static_cast<uint8_t>((*depth_old)[old] + 1);
      if ((*depth_old)[c] > levels) {
        return makeError(what, ": node ", c, " lies at depth ", int((*depth_old)[c]),
                         ", deeper than L = ", levels);
      }
      order->push_back(c);
    }
  }
  if (order->size() != n) {
    return makeError(what, ": ", n - order->size(),
                     " nodes are not reachable from the root (their parents form a cycle)");
  }
  return Ok{};
}

// Words: exactly the leaves, ids 0..W-1 each once, finite non-negative weights. Returns W.
Expected<size_t> checkWords(const std::vector<NodeSpec>& nodes, const Children& children,
                            const std::string& what) {
  const size_t n = nodes.size();
  size_t num_words = 0;
  for (size_t i = 0; i < n; ++i) {
    const bool leaf = children[i].empty();
    if (i == 0 && leaf) return makeError(what, ": the root has no children");
    if (leaf && nodes[i].word < 0) {
      return makeError(what, ": node ", i, " is a leaf without a word id");
    }
    if (!leaf && nodes[i].word >= 0) {
      return makeError(what, ": node ", i, " has children but is also word ", nodes[i].word);
    }
    if (leaf) ++num_words;
  }
  std::vector<bool> used(num_words, false);
  for (size_t i = 0; i < n; ++i) {
    const int64_t w = nodes[i].word;
    if (w < 0) continue;
    if (w >= static_cast<int64_t>(num_words)) {
      return makeError(what, ": node ", i, " has word id ", w, " but there are only ", num_words,
                       " words (ids must be 0..", num_words - 1, ")");
    }
    if (used[static_cast<size_t>(w)]) {
      return makeError(what, ": word id ", w, " is used by two nodes");
    }
    if (!std::isfinite(nodes[i].weight) || nodes[i].weight < 0.0) {
      return makeError(what, ": word ", w, " has weight ", nodes[i].weight,
                       " (must be finite and >= 0)");
    }
    used[static_cast<size_t>(w)] = true;
  }
  return num_words;
}

}  // namespace

Expected<Vocabulary> Vocabulary::create(int branching, int levels, std::vector<NodeSpec> nodes,
                                        const std::string& what) {
  if (branching < 2 || branching > kMaxBranching) {
    return makeError(what, ": branching factor k = ", branching, " is outside [2, ", kMaxBranching,
                     "]");
  }
  if (levels < 1 || levels > kMaxLevels) {
    return makeError(what, ": depth L = ", levels, " is outside [1, ", kMaxLevels, "]");
  }
  const size_t n = nodes.size();
  if (n < 2) return makeError(what, ": a vocabulary needs a root and at least one word");
  if (n >= kNoParent) return makeError(what, ": ", n, " nodes is too many");
  if (nodes[0].parent != -1) return makeError(what, ": node 0 must be the root (parent -1)");

  auto children = childrenOf(nodes, what);
  if (!children) return children.error();
  std::vector<uint32_t> order;  // order[new] = old
  std::vector<uint8_t> depth_old(n, 0);
  if (Status st = breadthFirst(*children, branching, levels, what, &order, &depth_old); !st) {
    return st.error();
  }
  const Expected<size_t> words = checkWords(nodes, *children, what);
  if (!words) return words.error();
  const size_t num_words = *words;

  Vocabulary v;
  v.branching_ = branching;
  v.levels_ = levels;
  std::vector<uint32_t> new_of_old(n);
  for (size_t k = 0; k < n; ++k) new_of_old[order[k]] = static_cast<uint32_t>(k);
  v.parent_.resize(n);
  v.first_child_.assign(n, 0);
  v.num_children_.resize(n);
  v.depth_.resize(n);
  v.word_of_node_.resize(n);
  v.descriptors_.resize(n);
  v.node_of_word_.resize(num_words);
  v.word_weight_.resize(num_words);
  for (size_t k = 0; k < n; ++k) {
    const uint32_t old = order[k];
    const NodeSpec& s = nodes[old];
    v.parent_[k] = k == 0 ? kNoParent : new_of_old[static_cast<size_t>(s.parent)];
    v.num_children_[k] = static_cast<uint32_t>((*children)[old].size());
    if (!(*children)[old].empty()) v.first_child_[k] = new_of_old[(*children)[old].front()];
    v.depth_[k] = depth_old[old];
    v.word_of_node_[k] = s.word;
    v.descriptors_[k] = k == 0 ? Descriptor{} : s.descriptor;
    if (s.word >= 0) {
      v.node_of_word_[static_cast<size_t>(s.word)] = static_cast<uint32_t>(k);
      v.word_weight_[static_cast<size_t>(s.word)] = s.weight;
    }
  }

  Fnv1a64 h;
  h.add(static_cast<uint32_t>(branching));
  h.add(static_cast<uint32_t>(levels));
  for (size_t k = 0; k < n; ++k) {
    h.add(v.parent_[k]);
    h.add(v.word_of_node_[k]);
    h.add(v.word_of_node_[k] >= 0 ? v.word_weight_[static_cast<size_t>(v.word_of_node_[k])] : 0.0);
    h.addBytes(v.descriptors_[k].bytes.data(), kDescriptorBytes);
  }
  v.fingerprint_ = h.value();
  return v;
}

EVERMAP_POPCNT_CLONES
uint32_t Vocabulary::descend(const Descriptor& d, int depth, uint32_t* node_at_depth) const {
  uint32_t node = 0;
  while (num_children_[node] > 0) {
    const uint32_t first = first_child_[node];
    const uint32_t end = first + num_children_[node];
    uint32_t best = first;
    int best_distance = hammingDistance(d, descriptors_[first]);
    for (uint32_t c = first + 1; c < end; ++c) {
      const int dist = hammingDistance(d, descriptors_[c]);
      if (dist < best_distance) {  // strict: the first child wins a tie, as in DBoW2
        best_distance = dist;
        best = c;
      }
    }
    node = best;
    if (depth_[node] == depth && node_at_depth) *node_at_depth = node;
  }
  if (node_at_depth && depth_[node] < depth) *node_at_depth = node;
  return static_cast<uint32_t>(word_of_node_[node]);
}

uint32_t Vocabulary::wordOf(const Descriptor& d) const { return descend(d, 0, nullptr); }

BowVector Vocabulary::transform(std::span<const Descriptor> descriptors) const {
  BowVector v;
  transform(descriptors, 1, &v, nullptr);
  return v;
}

void Vocabulary::transform(std::span<const Descriptor> descriptors, int direct_index_depth,
                           BowVector* bow, FeatureVector* direct) const {
  std::vector<std::pair<uint32_t, uint32_t>> words;   // (word, feature)
  std::vector<std::pair<uint32_t, uint32_t>> groups;  // (node at depth, feature)
  words.reserve(descriptors.size());
  if (direct) groups.reserve(descriptors.size());
  for (size_t i = 0; i < descriptors.size(); ++i) {
    uint32_t node = 0;
    const uint32_t w = descend(descriptors[i], direct_index_depth, direct ? &node : nullptr);
    words.emplace_back(w, static_cast<uint32_t>(i));
    if (direct) groups.emplace_back(node, static_cast<uint32_t>(i));
  }
  if (bow) {
    bow->clear();
    std::sort(words.begin(), words.end());
    double total = 0.0;
    for (size_t i = 0; i < words.size();) {
      size_t j = i;
      while (j < words.size() && words[j].first == words[i].first) ++j;
      // tf-idf: the count of the word times its idf; the L1 normalisation below divides by
      // the sum, which makes the count a term frequency.
      const double w = static_cast<double>(j - i) * word_weight_[words[i].first];
      if (w > 0.0) {
        bow->push_back({words[i].first, static_cast<float>(w)});
        total += w;
      }
      i = j;
    }
    for (auto& e : *bow) e.weight = static_cast<float>(e.weight / total);
  }
  if (direct) {
    direct->clear();
    std::sort(groups.begin(), groups.end());
    for (size_t i = 0; i < groups.size(); ++i) {
      if (direct->empty() || direct->back().node != groups[i].first) {
        direct->push_back({groups[i].first, {}});
      }
      direct->back().features.push_back(groups[i].second);
    }
  }
}

std::vector<size_t> Vocabulary::wordsPerDepth() const {
  std::vector<size_t> out(static_cast<size_t>(levels_) + 1, 0);
  for (uint32_t node : node_of_word_) ++out[depth_[node]];
  return out;
}

}  // namespace evermap::bow
