#pragma once
// Training a vocabulary tree from the descriptors of a set of images: hierarchical k-majority
// clustering (kmajority.h) to L levels, then idf weights counted over the same images
// (vocabulary.h states the model).

#include <cstdint>
#include <string>
#include <vector>

#include "core/bow/descriptor.h"
#include "core/bow/vocabulary.h"
#include "core/common/expected.h"
#include "core/common/option_fields.h"

namespace evermap::bow {

// k = 10 as DBoW2 and ORB-SLAM. With a few hundred thousand training descriptors, L = 5 leaves
// a handful per word at the bottom level (docs/place-recognition.md: what depth suits how much
// data). The same data and seed give the same vocabulary.
struct TrainingOptions {
  int branching = 10;
  int levels = 5;
  int max_iterations = 10;
  uint64_t seed = 1;

  void declareOptions(OptionList& o);
  Status validate() const { return checkOptionRanges(*this); }
};

struct TrainingSummary {
  size_t images = 0;
  size_t descriptors = 0;
  size_t nodes = 0;
  size_t words = 0;
  size_t zero_weight_words = 0;         // seen in every training image, or in none
  std::vector<size_t> words_per_depth;  // index = depth below the root
  size_t clustered_nodes = 0;           // inner nodes split by k-majority
  size_t unconverged_nodes = 0;         // of those, how many hit max_iterations
  std::string message;                  // one line for a person
};

// `images[i]` holds the descriptors of training image i (images without descriptors count
// towards N in the idf, as in DBoW2). Fails when there are no descriptors at all or the
// options are invalid.
Expected<Vocabulary> trainVocabulary(const std::vector<std::vector<Descriptor>>& images,
                                     const TrainingOptions& options,
                                     TrainingSummary* summary = nullptr);

}  // namespace evermap::bow
