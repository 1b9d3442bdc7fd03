#include "core/bow/place_store.h"

#include <bit>
#include <cinttypes>
#include <cstdio>
#include <string>

#include "core/messages/convert.h"

namespace evermap::bow {

namespace {

// A prepared statement that finalizes itself.
class Statement {
 public:
  Statement(sqlite3* db, const char* sql) {
    rc_ = sqlite3_prepare_v2(db, sql, -1, &stmt_, nullptr);
  }
  ~Statement() { sqlite3_finalize(stmt_); }
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;
  bool ok() const { return rc_ == SQLITE_OK && stmt_; }
  sqlite3_stmt* get() const { return stmt_; }

 private:
  sqlite3_stmt* stmt_ = nullptr;
  int rc_ = SQLITE_ERROR;
};

std::string hex16(uint64_t v) {
  char buf[17];
  std::snprintf(buf, sizeof(buf), "%016" PRIx64, v);
  return buf;
}

Error sqlError(const std::filesystem::path& file, sqlite3* db, const char* doing) {
  return makeError(file.string(), ": ", doing, ": ", db ? sqlite3_errmsg(db) : "out of memory");
}

// The vocabulary a store is bound to (bow_meta); empty strings when not written yet.
struct Binding {
  std::string version, fingerprint, words;

  Status check(const std::filesystem::path& file, uint64_t want_fingerprint,
               size_t want_words) const {
    if (version != std::to_string(kPlaceStoreSchemaVersion))
      return makeError(file.string(), ": place tables of schema version ",
                       version.empty() ? "(none)" : version, ", this build reads version ",
                       kPlaceStoreSchemaVersion);
    if (fingerprint != hex16(want_fingerprint) || words != std::to_string(want_words))
      return makeError(file.string(), ": places were made with vocabulary ", fingerprint, " (",
                       words, " words), not with ", hex16(want_fingerprint), " (", want_words,
                       " words)");
    return Ok{};
  }
};

Expected<Binding> readBinding(const std::filesystem::path& file, sqlite3* db) {
  Binding b;
  Statement q(db, "SELECT key, value FROM bow_meta");
  if (!q.ok()) return sqlError(file, db, "cannot read bow_meta");
  while (sqlite3_step(q.get()) == SQLITE_ROW) {
    const auto* k = reinterpret_cast<const char*>(sqlite3_column_text(q.get(), 0));
    const auto* v = reinterpret_cast<const char*>(sqlite3_column_text(q.get(), 1));
    if (!k || !v) continue;
    if (std::string(k) == "schema_version") b.version = v;
    if (std::string(k) == "vocabulary_fingerprint") b.fingerprint = v;
    if (std::string(k) == "num_words") b.words = v;
  }
  return b;
}

// The generated encoder indexes the arrays up to num_features without checking their sizes.
bool hasConsistentShape(const evermap::keyframe_t& k) {
  const auto n = static_cast<size_t>(k.num_features);
  if (k.num_features < 0 || k.keypoints.size() != n || k.points.size() != n ||
      k.disparity.size() != n || k.level.size() != n || k.descriptors.size() != n) {
    return false;
  }
  for (size_t i = 0; i < n; ++i) {
    if (k.keypoints[i].size() != 2 || k.points[i].size() != 3 || k.descriptors[i].size() != 32) {
      return false;
    }
  }
  return true;
}

}  // namespace

std::vector<uint8_t> encodeBowVector(const BowVector& v) {
  std::vector<uint8_t> out;
  out.reserve(8 * v.size());
  auto put = [&out](uint32_t x) {
    for (int i = 0; i < 4; ++i) out.push_back(static_cast<uint8_t>(x >> (8 * i)));
  };
  for (const WordWeight& e : v) {
    put(e.word);
    put(std::bit_cast<uint32_t>(e.weight));
  }
  return out;
}

Expected<BowVector> decodeBowVector(std::span<const uint8_t> blob, size_t num_words) {
  if (blob.size() % 8 != 0) {
    return makeError("BoW blob of ", blob.size(), " bytes is not a whole number of entries");
  }
  auto get = [&blob](size_t at) {
    uint32_t x = 0;
    for (int i = 0; i < 4; ++i) x |= static_cast<uint32_t>(blob[at + i]) << (8 * i);
    return x;
  };
  BowVector v(blob.size() / 8);
  for (size_t i = 0; i < v.size(); ++i) {
    v[i].word = get(8 * i);
    v[i].weight = std::bit_cast<float>(get(8 * i + 4));
  }
  if (!isWellFormed(v)) return makeError("BoW blob is not sorted or has a bad weight");
  if (!v.empty() && v.back().word >= num_words) {
    return makeError("BoW blob holds word ", v.back().word, " but the vocabulary has ", num_words);
  }
  return v;
}

PlaceStore::PlaceStore(sqlite3* db, std::filesystem::path file, uint64_t fingerprint,
                       size_t num_words)
    : db_(db), file_(std::move(file)), fingerprint_(fingerprint), num_words_(num_words) {}

PlaceStore::PlaceStore(PlaceStore&& o) noexcept
    : db_(o.db_),
      file_(std::move(o.file_)),
      fingerprint_(o.fingerprint_),
      num_words_(o.num_words_) {
  o.db_ = nullptr;
}

PlaceStore& PlaceStore::operator=(PlaceStore&& o) noexcept {
  if (this != &o) {
    sqlite3_close(db_);
    db_ = o.db_;
    o.db_ = nullptr;
    file_ = std::move(o.file_);
    fingerprint_ = o.fingerprint_;
    num_words_ = o.num_words_;
  }
  return *this;
}

PlaceStore::~PlaceStore() { sqlite3_close(db_); }

Status PlaceStore::exec(const char* sql) const {
  char* message = nullptr;
  if (sqlite3_exec(db_, sql, nullptr, nullptr, &message) != SQLITE_OK) {
    Error e = makeError(file_.string(), ": ", message ? message : "error", " (in: ", sql, ")");
    sqlite3_free(message);
    return e;
  }
  return Ok{};
}

Expected<PlaceStore> PlaceStore::open(const std::filesystem::path& file, uint64_t fingerprint,
                                      size_t num_words) {
  sqlite3* raw = nullptr;
  const int rc =
      sqlite3_open_v2(file.c_str(), &raw, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE, nullptr);
  PlaceStore store(raw, file, fingerprint, num_words);  // closes `raw` on every return below
  if (rc != SQLITE_OK) return sqlError(file, raw, "cannot open");
  sqlite3_busy_timeout(raw, 5000);  // another process of the map may hold the write lock

  {
    Statement wal(raw, "PRAGMA journal_mode=WAL");
    if (!wal.ok() || sqlite3_step(wal.get()) != SQLITE_ROW) {
      return sqlError(file, raw, "cannot switch to WAL (not an SQLite file?)");
    }
    const auto* mode = reinterpret_cast<const char*>(sqlite3_column_text(wal.get(), 0));
    if (!mode || std::string(mode) != "wal") {
      return makeError(file.string(), ": journal mode is ", mode ? mode : "?", ", not wal");
    }
  }
  // FULL: a committed batch survives a power cut too, at a cost irrelevant at 2 Hz.
  if (Status s = store.exec("PRAGMA synchronous=FULL"); !s) return s.error();
  if (Status s = store.exec(
          "BEGIN IMMEDIATE;"
          "CREATE TABLE IF NOT EXISTS bow_meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);"
          "CREATE TABLE IF NOT EXISTS bow_places (place_id INTEGER PRIMARY KEY, "
          "  floor INTEGER NOT NULL, utime INTEGER NOT NULL, words BLOB NOT NULL);"
          "CREATE TABLE IF NOT EXISTS keyframes (utime INTEGER PRIMARY KEY, "
          "  message BLOB NOT NULL);");
      !s) {
    return s.error();
  }
  auto rollback = [&store](Error e) -> Expected<PlaceStore> {
    (void)store.exec("ROLLBACK");
    return e;
  };
  // Read the binding; write it if the store is new.
  auto binding = readBinding(file, raw);
  if (!binding) return rollback(binding.error());
  if (binding->version.empty()) {
    Statement ins(raw, "INSERT INTO bow_meta (key, value) VALUES (?1, ?2)");
    if (!ins.ok()) return rollback(sqlError(file, raw, "cannot write bow_meta"));
    const std::string pairs[3][2] = {{"schema_version", std::to_string(kPlaceStoreSchemaVersion)},
                                     {"vocabulary_fingerprint", hex16(fingerprint)},
                                     {"num_words", std::to_string(num_words)}};
    for (const auto& kv : pairs) {
      sqlite3_reset(ins.get());
      sqlite3_bind_text(ins.get(), 1, kv[0].c_str(), -1, SQLITE_TRANSIENT);
      sqlite3_bind_text(ins.get(), 2, kv[1].c_str(), -1, SQLITE_TRANSIENT);
      if (sqlite3_step(ins.get()) != SQLITE_DONE) {
        return rollback(sqlError(file, raw, "cannot write bow_meta"));
      }
    }
  } else if (Status s = binding->check(file, fingerprint, num_words); !s) {
    return rollback(s.error());
  }
  if (Status s = store.exec("COMMIT"); !s) return rollback(s.error());
  return store;
}

bool PlaceStore::readOnly() const { return db_ && sqlite3_db_readonly(db_, "main") == 1; }

Expected<PlaceStore> PlaceStore::openReadOnly(const std::filesystem::path& file,
                                              uint64_t fingerprint, size_t num_words) {
  if (!std::filesystem::is_regular_file(file)) return makeError(file.string(), ": no such file");
  sqlite3* raw = nullptr;
  const int rc = sqlite3_open_v2(file.c_str(), &raw, SQLITE_OPEN_READONLY, nullptr);
  PlaceStore store(raw, file, fingerprint, num_words);  // closes `raw` on every return below
  if (rc != SQLITE_OK) return sqlError(file, raw, "cannot open");
  sqlite3_busy_timeout(raw, 5000);
  auto binding = readBinding(file, raw);
  if (!binding) return binding.error();
  if (Status s = binding->check(file, fingerprint, num_words); !s) return s.error();
  return store;
}

Status PlaceStore::savePlaces(std::span<const Place> batch) {
  for (const Place& p : batch) {
    if (!isWellFormed(p.bow) || (!p.bow.empty() && p.bow.back().word >= num_words_)) {
      return makeError(file_.string(), ": place ", p.id,
                       " has a BoW vector that is ill formed or not of this vocabulary");
    }
  }
  if (Status s = exec("BEGIN IMMEDIATE"); !s) return s;
  Statement ins(db_,
                "INSERT OR REPLACE INTO bow_places (place_id, floor, utime, words) "
                "VALUES (?1, ?2, ?3, ?4)");
  if (!ins.ok()) {
    Error e = sqlError(file_, db_, "cannot prepare the place insert");
    (void)exec("ROLLBACK");
    return e;
  }
  for (const Place& p : batch) {
    const std::vector<uint8_t> blob = encodeBowVector(p.bow);
    sqlite3_reset(ins.get());
    sqlite3_bind_int64(ins.get(), 1, p.id);
    sqlite3_bind_int(ins.get(), 2, p.floor);
    sqlite3_bind_int64(ins.get(), 3, p.utime);
    sqlite3_bind_blob(ins.get(), 4, blob.data(), static_cast<int>(blob.size()), SQLITE_TRANSIENT);
    if (sqlite3_step(ins.get()) != SQLITE_DONE) {
      Error e = sqlError(file_, db_, "cannot insert a place");
      (void)exec("ROLLBACK");
      return e;
    }
  }
  return exec("COMMIT");
}

Expected<std::vector<Place>> PlaceStore::loadPlaces() const {
  Statement q(db_, "SELECT place_id, floor, utime, words FROM bow_places ORDER BY place_id");
  if (!q.ok()) return sqlError(file_, db_, "cannot read bow_places");
  std::vector<Place> out;
  int rc;
  while ((rc = sqlite3_step(q.get())) == SQLITE_ROW) {
    Place p;
    p.id = sqlite3_column_int64(q.get(), 0);
    p.floor = sqlite3_column_int(q.get(), 1);
    p.utime = sqlite3_column_int64(q.get(), 2);
    const auto* data = static_cast<const uint8_t*>(sqlite3_column_blob(q.get(), 3));
    const int size = sqlite3_column_bytes(q.get(), 3);
    auto bow = decodeBowVector({data, static_cast<size_t>(size)}, num_words_);
    if (!bow) return makeError(file_.string(), ": place ", p.id, ": ", bow.error().message);
    p.bow = std::move(*bow);
    out.push_back(std::move(p));
  }
  if (rc != SQLITE_DONE) return sqlError(file_, db_, "cannot read bow_places");
  return out;
}

Expected<PlaceDatabase> PlaceStore::loadDatabase() const {
  auto places = loadPlaces();
  if (!places) return places.error();
  PlaceDatabase db(num_words_, fingerprint_);
  for (Place& p : *places) {
    if (Status s = db.insert(std::move(p)); !s)
      return makeError(file_.string(), ": ", s.error().message);
  }
  return db;
}

Status PlaceStore::saveKeyframes(std::span<const evermap::keyframe_t> batch) {
  std::vector<std::vector<uint8_t>> encoded;
  encoded.reserve(batch.size());
  for (const auto& k : batch) {
    if (!hasConsistentShape(k)) {
      return makeError(file_.string(), ": keyframe ", k.utime,
                       ": array sizes disagree with num_features = ", k.num_features);
    }
    const int size = k.getEncodedSize();
    std::vector<uint8_t> bytes(static_cast<size_t>(size));
    if (k.encode(bytes.data(), 0, size) != size) {
      return makeError(file_.string(), ": keyframe ", k.utime, " cannot be encoded");
    }
    encoded.push_back(std::move(bytes));
  }
  if (Status s = exec("BEGIN IMMEDIATE"); !s) return s;
  Statement ins(db_, "INSERT OR REPLACE INTO keyframes (utime, message) VALUES (?1, ?2)");
  if (!ins.ok()) {
    Error e = sqlError(file_, db_, "cannot prepare the keyframe insert");
    (void)exec("ROLLBACK");
    return e;
  }
  for (size_t i = 0; i < batch.size(); ++i) {
    sqlite3_reset(ins.get());
    sqlite3_bind_int64(ins.get(), 1, batch[i].utime);
    sqlite3_bind_blob(ins.get(), 2, encoded[i].data(), static_cast<int>(encoded[i].size()),
                      SQLITE_STATIC);
    if (sqlite3_step(ins.get()) != SQLITE_DONE) {
      Error e = sqlError(file_, db_, "cannot insert a keyframe");
      (void)exec("ROLLBACK");
      return e;
    }
  }
  return exec("COMMIT");
}

Expected<std::optional<evermap::keyframe_t>> PlaceStore::loadKeyframe(int64_t utime) const {
  Statement q(db_, "SELECT message FROM keyframes WHERE utime = ?1");
  if (!q.ok()) return sqlError(file_, db_, "cannot read keyframes");
  sqlite3_bind_int64(q.get(), 1, utime);
  const int rc = sqlite3_step(q.get());
  if (rc == SQLITE_DONE) return std::optional<evermap::keyframe_t>();
  if (rc != SQLITE_ROW) return sqlError(file_, db_, "cannot read keyframes");
  const void* data = sqlite3_column_blob(q.get(), 0);
  const int size = sqlite3_column_bytes(q.get(), 0);
  auto msg = messages::decodeLcm<evermap::keyframe_t>(
      data ? data : "", size, file_.string() + ": keyframe " + std::to_string(utime));
  if (!msg) return msg.error();
  return std::optional<evermap::keyframe_t>(std::move(*msg));
}

Expected<std::vector<int64_t>> PlaceStore::keyframeUtimes() const {
  Statement q(db_, "SELECT utime FROM keyframes ORDER BY utime");
  if (!q.ok()) return sqlError(file_, db_, "cannot read keyframes");
  std::vector<int64_t> out;
  int rc;
  while ((rc = sqlite3_step(q.get())) == SQLITE_ROW)
    out.push_back(sqlite3_column_int64(q.get(), 0));
  if (rc != SQLITE_DONE) return sqlError(file_, db_, "cannot read keyframes");
  return out;
}

}  // namespace evermap::bow
