#include "tools/vocab-train/vocabulary_training.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "tools/vocab-train/kmajority.h"

namespace evermap::bow {

void TrainingOptions::declareOptions(OptionList& o) {
  o.add("k", &branching, "", "branching factor: children per node").in(2, 64);
  o.add("levels", &levels, "", "depth L below the root: up to k^L words").in(1, 8);
  o.add("iterations", &max_iterations, "",
        "k-majority iterations per node at most (a node stops when its assignment is stable)")
      .min(1);
  o.add("seed", &seed, "", "seed of the k-means++ draws").any();
}

namespace {

// The tree without weights, breadth first: each pending node carries the training descriptors
// below it and is split by k-majority until `levels` or until its members are one descriptor.
Expected<std::vector<NodeSpec>> buildTree(const std::vector<Descriptor>& all,
                                          const TrainingOptions& options, TrainingSummary* s) {
  struct Pending {
    size_t node;
    int depth;
    std::vector<uint32_t> members;
  };
  std::vector<NodeSpec> nodes(1);  // the root
  std::vector<Pending> queue;
  queue.push_back({0, 0, {}});
  queue[0].members.resize(all.size());
  for (uint32_t i = 0; i < all.size(); ++i) queue[0].members[i] = i;
  SplitMix64 rng(options.seed);
  int64_t next_word = 0;
  for (size_t head = 0; head < queue.size(); ++head) {
    Pending p = std::move(queue[head]);
    bool split = false;
    if (p.depth < options.levels && p.members.size() > 1) {
      KMajorityResult r = kMajority(all, p.members, options.branching, options.max_iterations, rng);
      // One cluster means every member is the same descriptor: the node is a word.
      if (r.centres.size() > 1) {
        split = true;
        ++s->clustered_nodes;
        if (!r.converged) ++s->unconverged_nodes;
        for (size_t j = 0; j < r.centres.size(); ++j) {
          NodeSpec child;
          child.parent = static_cast<int64_t>(p.node);
          child.descriptor = r.centres[j];
          nodes.push_back(child);
          queue.push_back({nodes.size() - 1, p.depth + 1, std::move(r.members[j])});
        }
      }
    }
    if (!split) {
      if (p.node == 0)
        return makeError("vocabulary training: all ", all.size(), " descriptors are identical");
      nodes[p.node].word = next_word++;
    }
    std::vector<uint32_t>().swap(queue[head].members);
  }
  return nodes;
}

// idf: ln(N / n_w) over the training images (T-RO 2012, section IV); computed by quantising
// the training descriptors again through the finished tree, as DBoW2 does.
Status weightWords(const std::vector<std::vector<Descriptor>>& images,
                   const TrainingOptions& options, std::vector<NodeSpec>* nodes,
                   TrainingSummary* s) {
  auto unweighted =
      Vocabulary::create(options.branching, options.levels, *nodes, "trained vocabulary");
  if (!unweighted) return unweighted.error();
  const size_t num_words = unweighted->numWords();
  std::vector<uint32_t> images_with_word(num_words, 0);
  std::vector<uint32_t> last_image(num_words, UINT32_MAX);
  for (uint32_t i = 0; i < images.size(); ++i) {
    for (const Descriptor& d : images[i]) {
      const uint32_t w = unweighted->wordOf(d);
      if (last_image[w] != i) {
        last_image[w] = i;
        ++images_with_word[w];
      }
    }
  }
  const double n = static_cast<double>(images.size());
  for (NodeSpec& node : *nodes) {
    if (node.word < 0) continue;
    const uint32_t count = images_with_word[static_cast<size_t>(node.word)];
    node.weight = count > 0 ? std::log(n / count) : 0.0;
    if (node.weight <= 0.0) ++s->zero_weight_words;
  }
  return Ok{};
}

std::string summaryLine(const TrainingOptions& options, const TrainingSummary& s) {
  char line[256];
  std::snprintf(line, sizeof(line),
                "k=%d L=%d: %zu words (%zu of zero weight), %zu nodes from %zu descriptors of "
                "%zu images; %zu of %zu splits hit the iteration limit",
                options.branching, options.levels, s.words, s.zero_weight_words, s.nodes,
                s.descriptors, s.images, s.unconverged_nodes, s.clustered_nodes);
  return line;
}

}  // namespace

Expected<Vocabulary> trainVocabulary(const std::vector<std::vector<Descriptor>>& images,
                                     const TrainingOptions& options, TrainingSummary* summary) {
  if (Status s = options.validate(); !s) {
    return makeError("vocabulary training options: ", s.error().message);
  }
  std::vector<Descriptor> all;
  for (const auto& image : images) all.insert(all.end(), image.begin(), image.end());
  if (all.empty())
    return makeError("vocabulary training: no descriptors in ", images.size(), " images");

  TrainingSummary s;
  s.images = images.size();
  s.descriptors = all.size();
  auto nodes = buildTree(all, options, &s);
  if (!nodes) return nodes.error();
  if (Status st = weightWords(images, options, &*nodes, &s); !st) return st.error();
  auto vocabulary = Vocabulary::create(options.branching, options.levels, std::move(*nodes),
                                       "trained vocabulary");
  if (!vocabulary) return vocabulary.error();
  s.nodes = vocabulary->numNodes();
  s.words = vocabulary->numWords();
  s.words_per_depth = vocabulary->wordsPerDepth();
  s.message = summaryLine(options, s);
  if (summary) *summary = std::move(s);
  return vocabulary;
}

}  // namespace evermap::bow
