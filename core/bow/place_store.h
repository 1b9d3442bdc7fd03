#pragma once
// Persisting the place database (and the keyframes behind the places) in the map store: one
// SQLite file per map (DESIGN.md section 7), in WAL mode, written one transaction per batch,
// so a process killed at any moment leaves the last committed batch loadable. Other
// components keep their own tables in the same file; these are:
//
//   CREATE TABLE bow_meta   (key TEXT PRIMARY KEY, value TEXT NOT NULL);
//        -- 'schema_version' = '1', 'vocabulary_fingerprint' = 16 hex digits, 'num_words'
//   CREATE TABLE bow_places (place_id INTEGER PRIMARY KEY, floor INTEGER NOT NULL,
//                            utime INTEGER NOT NULL, words BLOB NOT NULL);
//        -- words: the BoW vector as n x (u32 word, f32 weight), little-endian
//   CREATE TABLE keyframes  (utime INTEGER PRIMARY KEY, message BLOB NOT NULL);
//        -- message: an LCM-encoded evermap keyframe_t (features, 3-D points, descriptors)
//
// A store is bound to the vocabulary its vectors came from (fingerprint and word count):
// opening it with another vocabulary is an error, never a silent comparison of vectors made
// by different trees.

#include <sqlite3.h>

#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <vector>

#include <evermap/keyframe_t.hpp>

#include "core/bow/place_database.h"
#include "core/common/expected.h"

namespace evermap::bow {

inline constexpr int kPlaceStoreSchemaVersion = 1;

class PlaceStore {
 public:
  // Opens (creating if needed) the SQLite file, switches it to WAL, creates the tables and
  // binds it to the vocabulary. Errors name the file.
  static Expected<PlaceStore> open(const std::filesystem::path& file,
                                   uint64_t vocabulary_fingerprint, size_t num_words);
  // Opens an existing store to read it only (SQLITE_OPEN_READONLY: localization, tools): no
  // file is created, nothing is written (the saves fail), the file's bytes do not change.
  // Errors: no such file, not a place store, another vocabulary.
  static Expected<PlaceStore> openReadOnly(const std::filesystem::path& file,
                                           uint64_t vocabulary_fingerprint, size_t num_words);
  PlaceStore(PlaceStore&& other) noexcept;
  PlaceStore& operator=(PlaceStore&& other) noexcept;
  PlaceStore(const PlaceStore&) = delete;
  PlaceStore& operator=(const PlaceStore&) = delete;
  ~PlaceStore();

  // One transaction; a place id already stored is replaced. Vectors are checked against the
  // vocabulary's word count.
  Status savePlaces(std::span<const Place> batch);
  // Every stored place, by increasing id (the insertion order of a map whose ids grow).
  Expected<std::vector<Place>> loadPlaces() const;
  // loadPlaces() inserted into a new database of this store's vocabulary.
  Expected<PlaceDatabase> loadDatabase() const;

  // One transaction; a keyframe utime already stored is replaced.
  Status saveKeyframes(std::span<const evermap::keyframe_t> batch);
  // nullopt when no keyframe has that utime; an error when the stored bytes do not decode.
  Expected<std::optional<evermap::keyframe_t>> loadKeyframe(int64_t utime) const;
  Expected<std::vector<int64_t>> keyframeUtimes() const;

  const std::filesystem::path& file() const { return file_; }
  // Opened by openReadOnly (SQLite's own answer for the main database).
  bool readOnly() const;

 private:
  PlaceStore(sqlite3* db, std::filesystem::path file, uint64_t fingerprint, size_t num_words);
  Status exec(const char* sql) const;

  sqlite3* db_ = nullptr;
  std::filesystem::path file_;
  uint64_t fingerprint_ = 0;
  size_t num_words_ = 0;
};

// The blob encoding of a BoW vector used by bow_places.words (exposed for tests and tools).
std::vector<uint8_t> encodeBowVector(const BowVector& v);
Expected<BowVector> decodeBowVector(std::span<const uint8_t> blob, size_t num_words);

}  // namespace evermap::bow
