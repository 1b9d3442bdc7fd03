#pragma once
// The map store's file (DESIGN.md section 7): one SQLite file per map, WAL, so that a process
// killed at any moment leaves the last committed map loadable. The mapper writes it
// (mapper-proc/map_store.h), readers load it (core/map/store_reader.h); this is where its
// schema is written and migrated. Other components keep their own tables in the same file;
// the map's are:
//
//   CREATE TABLE map_sessions (session_id INTEGER PRIMARY KEY, start_utime INTEGER NOT NULL);
//   CREATE TABLE map_floors   (floor_index INTEGER PRIMARY KEY, height_m REAL NOT NULL);
//   CREATE TABLE map_nodes    (node_id INTEGER PRIMARY KEY, session_id INTEGER NOT NULL,
//                              floor INTEGER NOT NULL, keyframe_utime INTEGER NOT NULL,
//                              pose BLOB NOT NULL);   -- world_T_body: x y z qw qx qy qz (f64)
//   CREATE TABLE map_edges    (edge_id INTEGER PRIMARY KEY, from_node INTEGER NOT NULL,
//                              to_node INTEGER NOT NULL, kind INTEGER NOT NULL,
//                              accepted INTEGER NOT NULL, utime INTEGER NOT NULL,
//                              pose BLOB NOT NULL,         -- from_T_to, as above
//                              covariance BLOB NOT NULL);  -- 36 f64, row-major, (υ, ω)
//   CREATE TABLE map_attitude (node_id INTEGER PRIMARY KEY, roll_rad REAL NOT NULL,
//                              pitch_rad REAL NOT NULL,
//                              covariance BLOB NOT NULL);  -- 4 f64, row-major, (roll, pitch)
//   CREATE TABLE map_folds    (edge_id INTEGER PRIMARY KEY, members INTEGER NOT NULL,
//                              rejected INTEGER NOT NULL, first_utime INTEGER NOT NULL);
//   CREATE TABLE map_saved    (session_id INTEGER PRIMARY KEY,   -- the mapper that started
//                              constraints INTEGER NOT NULL);    -- it: how many of its
//                                                                -- constraints are stored
//   CREATE TABLE map_tracking (id INTEGER PRIMARY KEY CHECK (id = 0),  -- one row, or none
//                              utime INTEGER NOT NULL, session_id INTEGER NOT NULL,
//                              session_start_utime INTEGER NOT NULL, active_node INTEGER NOT NULL,
//                              floor INTEGER NOT NULL, in_elevator INTEGER NOT NULL,
//                              pose BLOB NOT NULL,         -- active_T_body, as above
//                              covariance BLOB NOT NULL,   -- 36 f64, row-major, (υ, ω)
//                              -- version 2: the odometry pose of Δ's VO frame, or all NULL
//                              odom_epoch INTEGER, odom_utime INTEGER,
//                              odom_pose BLOB,             -- odom_T_cam, as above
//                              odom_covariance BLOB,       -- 36 f64, as above
//                              odom_own_covariance BLOB,   -- the frame's motion from its
//                                                          -- keyframe, 36 f64
//                              -- version 3: the wheels' odometry pose at Δ's time, or NULL
//                              wheel_epoch INTEGER, wheel_utime INTEGER,
//                              wheel_pose BLOB,            -- 3 f64: x, y, θ
//                              wheel_covariance BLOB);     -- 9 f64, row-major (x, y, θ)
//   CREATE TABLE map_footprints (footprint_id INTEGER PRIMARY KEY,  -- in the order made
//                                node_id INTEGER NOT NULL,          -- a place seen from
//                                session_id INTEGER NOT NULL,       -- in this session:
//                                x REAL NOT NULL, y REAL NOT NULL,  -- node_T_view, planar
//                                theta REAL NOT NULL);              --
//                                (mapper-proc/view_footprints.h)
//
// Schema versions (PRAGMA user_version): 0, stores made before map_tracking (they open and
// are migrated by creating it: a store without a row restarts lost, as before); 1, with
// map_tracking but not its odom_* columns (migrated by adding them, NULL: the state restarts
// warm without the odometry bridge); 2, without the wheel_* columns (migrated by adding them:
// restarts warm, bridged by VO's odometry frame only); 3, without map_footprints (migrated by
// creating it: the map restarts with no footprint, and files them anew); 4, this one. A read-only
// open reads an older store as it is. A store of a newer version is refused (its rows may mean what
// this code does not know).

#include <sqlite3.h>

#include <cstdint>
#include <filesystem>
#include <string>
#include <utility>

#include "core/common/expected.h"

namespace evermap::map {

// PRAGMA user_version of the schema this code writes (above).
inline constexpr int64_t kSchemaVersion = 4;

// The map_tracking columns each version after 1 added (a store is migrated by adding them;
// a read-only open of an older store reads them as NULL).
inline constexpr std::pair<const char*, const char*> kTrackingColumnsAdded[] = {
    // version 2: the VO odometry pose
    {"odom_epoch", "INTEGER"},
    {"odom_utime", "INTEGER"},
    {"odom_pose", "BLOB"},
    {"odom_covariance", "BLOB"},
    {"odom_own_covariance", "BLOB"},
    // version 3: the wheels' odometry pose
    {"wheel_epoch", "INTEGER"},
    {"wheel_utime", "INTEGER"},
    {"wheel_pose", "BLOB"},
    {"wheel_covariance", "BLOB"}};

// A prepared statement, finalised on every path.
struct Statement {
  sqlite3_stmt* s = nullptr;
  Statement() = default;
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;
  ~Statement() { sqlite3_finalize(s); }
};

// One open map store: the SQLite connection, its schema, and the small queries its reader and
// writer share. Errors name the file.
class StoreFile {
 public:
  // read_only: an existing store, to read it only (a viewer): no file is created and the schema
  // is not touched. Otherwise the file is created if needed, switched to WAL, and its tables
  // created or migrated to kSchemaVersion. A store of a newer version, or a file that is not a
  // map store, is refused.
  static Expected<StoreFile> open(const std::filesystem::path& file, bool read_only);
  StoreFile(StoreFile&& other) noexcept;
  StoreFile& operator=(StoreFile&& other) noexcept;
  StoreFile(const StoreFile&) = delete;
  StoreFile& operator=(const StoreFile&) = delete;
  ~StoreFile();

  sqlite3* db() const { return db_; }
  const std::filesystem::path& path() const { return file_; }
  bool readOnly() const { return read_only_; }

  Status exec(const char* sql) const;
  // Prepares `sql` into st; false on failure (then sqliteError() says why).
  bool prepare(Statement& st, const char* sql) const;
  // "<file>: <SQLite's last error>", or "<file>: <what>: <...>".
  Error sqliteError() const;
  Error sqliteError(const char* what) const;
  // The first column of the first row of `sql`, with ?1 = a and ?2 = b.
  Expected<int64_t> queryInt(const char* sql, int64_t a = 0, int64_t b = 0) const;
  // Whether the file has `table` (a store of an older schema, opened read-only, lacks the
  // later ones).
  Expected<bool> hasTable(const char* table) const;
  // Whether map_tracking has `column` (a store of an older schema lacks the later ones).
  Expected<bool> hasTrackingColumn(const char* column) const;

  // The highest edge id in the file (-1: none).
  Expected<int64_t> lastEdgeId() const;
  // Rows of map_edges (a fold is one).
  Expected<int64_t> edgeRows() const { return queryInt("SELECT COUNT(*) FROM map_edges"); }
  // PRAGMA user_version: the schema's version (above).
  Expected<int64_t> schemaVersion() const { return queryInt("PRAGMA user_version"); }
  // PRAGMA integrity_check == "ok".
  Status integrityCheck() const;

 private:
  StoreFile(sqlite3* db, std::filesystem::path file, bool read_only)
      : db_(db), file_(std::move(file)), read_only_(read_only) {}
  // Creates the tables a store of `version` lacks and sets kSchemaVersion.
  Status createOrMigrate(int64_t version) const;
  // The map_tracking columns of later versions the table lacks, added in one transaction (a
  // kill leaves the older version whole).
  Status addTrackingColumns() const;

  sqlite3* db_ = nullptr;
  std::filesystem::path file_;
  bool read_only_ = false;
};

}  // namespace evermap::map
