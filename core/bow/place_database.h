#pragma once
// A database of places for appearance search (DESIGN.md section 5): each place is a map node
// (or any image) described by its bag-of-words vector, on a floor, at a time. An inverted
// index (word -> places that contain it, per floor) makes a query cost proportional to the
// places that share words with it, not to the size of the map.
//
// Scores are DBoW2's normalised L1 score (bow_vector.h), in [0, 1]; 1 means identical word
// distributions. Optionally a query carries a reference score — the score of the query against
// an image known to show the same place, normally the previous keyframe — and each result then
// also has DBoW2's normalised similarity score / reference (T-RO 2012, eq. 3), which removes
// the dependence of raw scores on how many distinctive words an image has.
//
// Threading: insert() needs exclusive access; concurrent query() calls are safe.

#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include "core/bow/bow_vector.h"
#include "core/common/expected.h"

namespace evermap::bow {

struct Place {
  int64_t id = 0;     // unique (a map node id)
  int32_t floor = 0;  // floor index
  int64_t utime = 0;  // microseconds: time of the keyframe that describes the place
  BowVector bow;      // from the database's vocabulary
};

struct PlaceQuery {
  // Only places on this floor; nullopt searches every floor.
  std::optional<int32_t> floor;
  // Recent-frame exclusion, so that the frames just before the query (which look alike
  // because they *are* just before it) are not reported as loop closures:
  //   by time: places with utime > newest_utime are skipped;
  int64_t newest_utime = std::numeric_limits<int64_t>::max();
  //   by id: places with id > newest_id are skipped (node ids grow with time).
  int64_t newest_id = std::numeric_limits<int64_t>::max();
  // How many results at most, best first.
  int top_k = 10;
  // Results with score below this are not returned.
  double min_score = 0.0;
  // If > 0: each match also gets normalized_score = score / reference_score.
  double reference_score = 0.0;

  std::string validate() const;  // empty when valid
};

struct PlaceMatch {
  int64_t id = 0;
  int32_t floor = 0;
  int64_t utime = 0;
  double score = 0.0;             // normalised L1, [0, 1]
  double normalized_score = 0.0;  // score / reference_score, or 0 without a reference
};

class PlaceDatabase {
 public:
  // `num_words` and `vocabulary_fingerprint` of the vocabulary that made the vectors.
  PlaceDatabase(size_t num_words, uint64_t vocabulary_fingerprint);

  // Errors: duplicate id, a vector that is not well formed or holds a word >= num_words.
  Status insert(Place place);
  // Best places first (ties by smaller id). An ill-formed query vector gives an error.
  Expected<std::vector<PlaceMatch>> query(const BowVector& bow, const PlaceQuery& q) const;

  size_t size() const { return places_.size(); }
  size_t numWords() const { return num_words_; }
  uint64_t vocabularyFingerprint() const { return fingerprint_; }
  // In insertion order.
  const std::vector<Place>& places() const { return places_; }
  const Place* find(int64_t id) const;
  // Number of postings (place, word) held by the inverted index, over all floors.
  size_t numPostings() const { return num_postings_; }
  // Number of posting lists (floor, word) the index holds: at most numPostings().
  size_t numPostingLists() const;

 private:
  struct Posting {
    uint32_t place;  // index into places_
    float weight;
  };
  // Inverted index of one floor: the postings of each word present on it, in insertion
  // order. Sparse, so its memory grows with the postings, not with floors x vocabulary size:
  // a dense array of num_words lists per floor cost 24 bytes x num_words (1.5 MB with the
  // 65,140-word default vocabulary) for every floor label ever inserted, which is how fuzzed
  // NODE_ADDED with random floors grew loopclose-proc from 28 to 210 MB (issue 17).
  struct FloorIndex {
    std::unordered_map<uint32_t, std::vector<Posting>> postings;
  };
  void accumulate(const FloorIndex& index, const BowVector& bow, std::vector<float>& score) const;

  size_t num_words_;
  uint64_t fingerprint_;
  std::vector<Place> places_;
  std::unordered_map<int64_t, uint32_t> index_of_id_;
  std::unordered_map<int32_t, FloorIndex> floors_;
  size_t num_postings_ = 0;
};

}  // namespace evermap::bow
