#include "core/map/store_file.h"

#include <string>
#include <utility>

namespace evermap::map {
namespace {

// Every table of kSchemaVersion but map_tracking's later columns (kTrackingColumnsAdded).
constexpr const char* kSchema =
    // Before the first table: a new store gives the pages a fold or a moved pose freed back
    // to the file system after each save (an older store keeps its mode; VACUUM converts it).
    "PRAGMA auto_vacuum=INCREMENTAL;"
    "PRAGMA journal_mode=WAL;"
    "PRAGMA synchronous=NORMAL;"
    "CREATE TABLE IF NOT EXISTS map_sessions (session_id INTEGER PRIMARY KEY, start_utime "
    "INTEGER NOT NULL);"
    "CREATE TABLE IF NOT EXISTS map_floors (floor_index INTEGER PRIMARY KEY, height_m REAL NOT "
    "NULL);"
    "CREATE TABLE IF NOT EXISTS map_nodes (node_id INTEGER PRIMARY KEY, session_id INTEGER NOT "
    "NULL,"
    " floor INTEGER NOT NULL, keyframe_utime INTEGER NOT NULL, pose BLOB NOT NULL);"
    "CREATE TABLE IF NOT EXISTS map_edges (edge_id INTEGER PRIMARY KEY, from_node INTEGER NOT "
    "NULL,"
    " to_node INTEGER NOT NULL, kind INTEGER NOT NULL, accepted INTEGER NOT NULL, utime INTEGER "
    "NOT NULL,"
    " pose BLOB NOT NULL, covariance BLOB NOT NULL);"
    "CREATE TABLE IF NOT EXISTS map_attitude (node_id INTEGER PRIMARY KEY, roll_rad REAL NOT "
    "NULL,"
    " pitch_rad REAL NOT NULL, covariance BLOB NOT NULL);"
    "CREATE TABLE IF NOT EXISTS map_folds (edge_id INTEGER PRIMARY KEY, members INTEGER NOT NULL,"
    " rejected INTEGER NOT NULL, first_utime INTEGER NOT NULL);"
    "CREATE INDEX IF NOT EXISTS map_edges_pair ON map_edges (from_node, to_node);"
    "CREATE TABLE IF NOT EXISTS map_saved (session_id INTEGER PRIMARY KEY, constraints INTEGER "
    "NOT NULL);"
    // Version 1: the tracking state (a version-0 store is migrated by this line); the columns
    // of later versions are added by addTrackingColumns.
    "CREATE TABLE IF NOT EXISTS map_tracking (id INTEGER PRIMARY KEY CHECK (id = 0), utime "
    "INTEGER NOT NULL,"
    " session_id INTEGER NOT NULL, session_start_utime INTEGER NOT NULL, active_node INTEGER NOT "
    "NULL,"
    " floor INTEGER NOT NULL, in_elevator INTEGER NOT NULL, pose BLOB NOT NULL, covariance BLOB "
    "NOT NULL);"
    // Version 4: the nodes' footprints (an older store is migrated by this line, empty).
    "CREATE TABLE IF NOT EXISTS map_footprints (footprint_id INTEGER PRIMARY KEY, node_id "
    "INTEGER NOT NULL, session_id INTEGER NOT NULL, x REAL NOT NULL, y REAL NOT NULL, theta REAL "
    "NOT NULL);";

}  // namespace

Expected<StoreFile> StoreFile::open(const std::filesystem::path& file, bool read_only) {
  sqlite3* db = nullptr;
  const int flags = read_only ? SQLITE_OPEN_READONLY : SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE;
  if (sqlite3_open_v2(file.c_str(), &db, flags, nullptr) != SQLITE_OK) {
    std::string msg = db ? sqlite3_errmsg(db) : "out of memory";
    sqlite3_close(db);
    return makeError(file.string(), ": cannot open map store (", msg, ")");
  }
  StoreFile store(db, file, read_only);
  auto version = store.schemaVersion();
  if (!version) return version.error();
  if (*version > kSchemaVersion)
    return makeError(file.string(), ": map store schema version ", *version,
                     ", newer than this program's ", kSchemaVersion);
  if (!read_only) {
    if (Status s = store.createOrMigrate(*version); !s) return s.error();
  }
  // A file that is no map store has no map_edges (a read-write open created it).
  Statement st;
  if (!store.prepare(st, "SELECT COALESCE(MAX(edge_id), -1) FROM map_edges") ||
      sqlite3_step(st.s) != SQLITE_ROW)
    return makeError(file.string(), ": not a map store (", sqlite3_errmsg(db), ")");
  return store;
}

Status StoreFile::createOrMigrate(int64_t version) const {
  if (Status s = exec(kSchema); !s) return s;
  if (Status s = addTrackingColumns(); !s) return s;
  if (version < kSchemaVersion) {
    const std::string set = "PRAGMA user_version=" + std::to_string(kSchemaVersion);
    if (Status s = exec(set.c_str()); !s) return s;
  }
  return Ok{};
}

Status StoreFile::addTrackingColumns() const {
  std::string migrate;
  for (const auto& [column, type] : kTrackingColumnsAdded) {
    auto has = hasTrackingColumn(column);
    if (!has) return has.error();
    if (!*has)
      migrate += std::string("ALTER TABLE map_tracking ADD COLUMN ") + column + " " + type + ";";
  }
  if (migrate.empty()) return Ok{};
  if (Status s = exec(("BEGIN IMMEDIATE;" + migrate + "COMMIT;").c_str()); !s) {
    (void)exec("ROLLBACK");
    return s;
  }
  return Ok{};
}

StoreFile::StoreFile(StoreFile&& o) noexcept
    : db_(std::exchange(o.db_, nullptr)), file_(std::move(o.file_)), read_only_(o.read_only_) {}
StoreFile& StoreFile::operator=(StoreFile&& o) noexcept {
  if (this != &o) {
    sqlite3_close(db_);
    db_ = std::exchange(o.db_, nullptr);
    file_ = std::move(o.file_);
    read_only_ = o.read_only_;
  }
  return *this;
}
StoreFile::~StoreFile() { sqlite3_close(db_); }

Status StoreFile::exec(const char* sql) const {
  char* err = nullptr;
  if (sqlite3_exec(db_, sql, nullptr, nullptr, &err) != SQLITE_OK) {
    std::string m = err ? err : "unknown error";
    sqlite3_free(err);
    return makeError(file_.string(), ": ", m);
  }
  return Ok{};
}

bool StoreFile::prepare(Statement& st, const char* sql) const {
  return sqlite3_prepare_v2(db_, sql, -1, &st.s, nullptr) == SQLITE_OK;
}

Error StoreFile::sqliteError() const {
  return makeError(file_.string(), ": ", sqlite3_errmsg(db_));
}

Error StoreFile::sqliteError(const char* what) const {
  return makeError(file_.string(), ": ", what, ": ", sqlite3_errmsg(db_));
}

Expected<int64_t> StoreFile::queryInt(const char* sql, int64_t a, int64_t b) const {
  Statement st;
  if (!prepare(st, sql)) return sqliteError();
  sqlite3_bind_int64(st.s, 1, a);
  if (sqlite3_bind_parameter_count(st.s) >= 2) sqlite3_bind_int64(st.s, 2, b);
  if (sqlite3_step(st.s) != SQLITE_ROW) return sqliteError();
  return sqlite3_column_int64(st.s, 0);
}

Expected<bool> StoreFile::hasTable(const char* table) const {
  const std::string sql =
      std::string("SELECT COUNT(*) FROM sqlite_master WHERE type = 'table' AND name = '") + table +
      "'";
  auto count = queryInt(sql.c_str());
  if (!count) return count.error();
  return *count > 0;
}

Expected<bool> StoreFile::hasTrackingColumn(const char* column) const {
  const std::string sql =
      std::string("SELECT COUNT(*) FROM pragma_table_info('map_tracking') WHERE name = '") +
      column + "'";
  auto count = queryInt(sql.c_str());
  if (!count) return count.error();
  return *count > 0;
}

Expected<int64_t> StoreFile::lastEdgeId() const {
  return queryInt("SELECT COALESCE(MAX(edge_id), -1) FROM map_edges");
}

Status StoreFile::integrityCheck() const {
  Statement st;
  if (!prepare(st, "PRAGMA integrity_check") || sqlite3_step(st.s) != SQLITE_ROW)
    return makeError(file_.string(), ": integrity_check failed to run");
  const char* r = reinterpret_cast<const char*>(sqlite3_column_text(st.s, 0));
  if (!r || std::string(r) != "ok")
    return makeError(file_.string(), ": integrity_check: ", r ? r : "(null)");
  return Ok{};
}

}  // namespace evermap::map
