#pragma once
// The mapper's part of the map store (DESIGN.md section 7): one SQLite file per map, WAL,
// one transaction per update, so a process killed at any moment leaves the last committed
// map loadable. Other components keep their own tables in the same file; these are:
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
//
// Every constraint is an edge (accepted or rejected, DESIGN.md section 3); node poses are
// the latest estimates and are rewritten in the transaction of each update.

#include <sqlite3.h>

#include <cstdint>
#include <filesystem>
#include <vector>

#include "core/common/expected.h"
#include "core/geometry/se3.h"
#include "mapper-proc/constraint_set.h"
#include "mapper-proc/mapper.h"

namespace evermap::mapper {

struct StoredNode {
  MapperNode node;
  core::SE3d world_T_body;
};

struct StoredEdge {
  int64_t edge_id = 0;
  Constraint constraint;
};

struct MapSnapshot {
  std::vector<std::pair<int, int64_t>> sessions;  // (session, start utime)
  std::vector<std::pair<int, double>> floors;     // (floor index, height m)
  std::vector<StoredNode> nodes;                  // by id
  std::vector<StoredEdge> edges;                  // by id
};

class MapStore {
 public:
  // Opens (creating if needed) the file, switches it to WAL and creates the tables. Errors
  // name the file.
  static Expected<MapStore> open(const std::filesystem::path& file);
  MapStore(MapStore&& other) noexcept;
  MapStore& operator=(MapStore&& other) noexcept;
  MapStore(const MapStore&) = delete;
  MapStore& operator=(const MapStore&) = delete;
  ~MapStore();

  // One transaction: the session row, the floors, every node (inserted or its pose updated)
  // and the edges not stored yet (edge ids are indices into the constraint set).
  Status save(const Mapper& mapper, int session, int64_t session_start_utime);
  Expected<MapSnapshot> load() const;
  // PRAGMA integrity_check == "ok".
  Status integrityCheck() const;

 private:
  explicit MapStore(sqlite3* db, std::filesystem::path file) : db_(db), file_(std::move(file)) {}
  Status exec(const char* sql) const;

  sqlite3* db_ = nullptr;
  std::filesystem::path file_;
  int64_t edges_stored_ = -1;  // highest edge id in the file, read at open
};

}  // namespace evermap::mapper
