#include "core/bow/place_database.h"

#include <algorithm>
#include <cmath>

namespace evermap::bow {

std::string PlaceQuery::validate() const {
  if (top_k < 1) return "top_k must be >= 1, got " + std::to_string(top_k);
  if (!std::isfinite(min_score)) return "min_score must be finite";
  if (!std::isfinite(reference_score) || reference_score < 0.0) {
    return "reference_score must be finite and >= 0";
  }
  return {};
}

PlaceDatabase::PlaceDatabase(size_t num_words, uint64_t vocabulary_fingerprint)
    : num_words_(num_words), fingerprint_(vocabulary_fingerprint) {}

Status PlaceDatabase::insert(Place place) {
  if (index_of_id_.count(place.id)) {
    return makeError("place ", place.id, ": already in the database");
  }
  if (!isWellFormed(place.bow)) {
    return makeError("place ", place.id,
                     ": bag-of-words vector is not sorted by word or has a weight that is not "
                     "finite and > 0");
  }
  if (!place.bow.empty() && place.bow.back().word >= num_words_) {
    return makeError("place ", place.id, ": word ", place.bow.back().word,
                     " is not in the vocabulary (", num_words_, " words)");
  }
  if (places_.size() >= std::numeric_limits<uint32_t>::max()) {
    return makeError("place ", place.id, ": the database is full");
  }
  const auto index = static_cast<uint32_t>(places_.size());
  FloorIndex& f = floors_[place.floor];
  for (const WordWeight& e : place.bow) f.postings[e.word].push_back({index, e.weight});
  num_postings_ += place.bow.size();
  index_of_id_.emplace(place.id, index);
  places_.push_back(std::move(place));
  return Ok{};
}

size_t PlaceDatabase::numPostingLists() const {
  size_t n = 0;
  for (const auto& [floor, index] : floors_) n += index.postings.size();
  return n;
}

const Place* PlaceDatabase::find(int64_t id) const {
  auto it = index_of_id_.find(id);
  return it == index_of_id_.end() ? nullptr : &places_[it->second];
}

void PlaceDatabase::accumulate(const FloorIndex& index, const BowVector& bow,
                               std::vector<float>& score) const {
  for (const WordWeight& q : bow) {
    // Normalised L1 = sum over common words of min(q_w, p_w) (bow_vector.h). No branch per
    // posting: the places that scored are found by one pass over `score` afterwards.
    const auto it = index.postings.find(q.word);
    if (it == index.postings.end()) continue;
    for (const Posting& p : it->second) score[p.place] += std::min(q.weight, p.weight);
  }
}

Expected<std::vector<PlaceMatch>> PlaceDatabase::query(const BowVector& bow,
                                                       const PlaceQuery& q) const {
  if (std::string why = q.validate(); !why.empty()) return makeError("place query: ", why);
  if (!isWellFormed(bow) || (!bow.empty() && bow.back().word >= num_words_)) {
    return makeError(
        "place query: bag-of-words vector is ill formed or not of this "
        "vocabulary (",
        num_words_, " words)");
  }
  std::vector<float> score(places_.size(), 0.0f);
  if (q.floor) {
    auto it = floors_.find(*q.floor);
    if (it != floors_.end()) accumulate(it->second, bow, score);
  } else {
    for (const auto& [floor, index] : floors_) accumulate(index, bow, score);
  }

  std::vector<PlaceMatch> out;
  for (uint32_t i = 0; i < places_.size(); ++i) {
    if (score[i] <= 0.0f) continue;  // shares no word with the query
    const Place& p = places_[i];
    if (p.utime > q.newest_utime || p.id > q.newest_id) continue;
    const double s = std::min(1.0, static_cast<double>(score[i]));
    if (s < q.min_score) continue;
    PlaceMatch m;
    m.id = p.id;
    m.floor = p.floor;
    m.utime = p.utime;
    m.score = s;
    m.normalized_score = q.reference_score > 0.0 ? s / q.reference_score : 0.0;
    out.push_back(m);
  }
  auto better = [](const PlaceMatch& a, const PlaceMatch& b) {
    return a.score != b.score ? a.score > b.score : a.id < b.id;
  };
  const size_t k = std::min(out.size(), static_cast<size_t>(q.top_k));
  std::partial_sort(out.begin(), out.begin() + static_cast<std::ptrdiff_t>(k), out.end(), better);
  out.resize(k);
  return out;
}

}  // namespace evermap::bow
