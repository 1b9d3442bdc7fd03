#pragma once
// The mapper's part of the map store (DESIGN.md section 7): one SQLite file per map, WAL,
// one transaction per update (then a checkpoint that empties the log), so a process killed at any
// moment leaves the last committed map loadable. Other components keep their own tables in the same
// file; these are:
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
//
// The tracking state (Mapper::trackingState: the node tracked against, Δ, floor, session,
// message time) is written in every save's transaction with the map it refers to, and on its
// own by saveTracking() between them; no row while the mapper is lost. A restarted mapper
// resumes from it (MapperOptions::warm_restart_max_gap_s).
//
// Schema versions (PRAGMA user_version): 0, stores made before map_tracking (they open and
// are migrated by creating it: a store without a row restarts lost, as before); 1, with
// map_tracking but not its odom_* columns (migrated by adding them, NULL: the state restarts
// warm without the odometry bridge); 2, without the wheel_* columns (migrated by adding them:
// restarts warm, bridged by VO's odometry frame only); 3, this one. A read-only open reads an
// older store as it is.
// A store of a newer version is refused (its rows may mean what this code does not know).
//
// Every constraint is an edge (accepted or rejected, DESIGN.md section 3) until its pair is
// folded; node poses are the latest estimates, rewritten in an update's transaction when they
// moved.
//
// Folding (paper section I: the graph, and so the store, grows with the area, not with the
// time): once a pair of nodes holds `fold_after` rows, the transaction that adds the last one
// replaces them by one row, the pair's merged estimate (ConstraintSet::Pair::i_T_j, the
// information-weighted fusion of its accepted constraints), with a map_folds row saying how
// many accepted and rejected constraints it stands for and since when. The row keeps the id
// of the pair's oldest row, and so its place in the file: folds rewrite a pair's row in place,
// and a map visited again and again keeps its size. A restored mapper adds
// it as the pair's first constraint, so the pair's factor and the gate for its next
// constraints are what they were. A fold is undone as a whole: deleting its row removes the
// pair's evidence (the next visit registers the pair anew); the single constraints folded
// into it are not kept.

#include <sqlite3.h>

#include <cstdint>
#include <filesystem>
#include <optional>
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
  int64_t edge_id = 0;  // increasing in the order the constraints were made
  Constraint constraint;
  int64_t folded = 0;  // > 0: a fold of this many accepted constraints (map_folds)
  int64_t folded_rejected = 0;
};

struct MapStoreOptions {
  // A pair's rows are folded into one when they reach this many (0: never fold). 2: a pair's
  // second constraint, accepted by the gate, agrees with the first and is folded with it.
  int fold_after = 2;
  // Open an existing store to read it only (a viewer): no file is created, the schema is not
  // touched and save() refuses.
  bool read_only = false;
};

struct MapSnapshot {
  std::vector<std::pair<int, int64_t>> sessions;  // (session, start utime)
  std::vector<std::pair<int, double>> floors;     // (floor index, height m)
  std::vector<StoredNode> nodes;                  // by id
  std::vector<StoredEdge> edges;                  // by id
  std::optional<TrackingState> tracking;          // map_tracking's row, if any
  int max_saved_mapper = -1;                      // highest session_id of map_saved

  // How many constraints the edges stand for (a fold counts its members, accepted and
  // rejected): every constraint ever made, folded or not.
  int64_t constraintsRepresented() const {
    int64_t n = 0;
    for (const StoredEdge& e : edges) n += e.folded > 0 ? e.folded + e.folded_rejected : 1;
    return n;
  }
};

class MapStore {
 public:
  // Opens (creating if needed) the file, switches it to WAL and creates the tables. Errors
  // name the file.
  static Expected<MapStore> open(const std::filesystem::path& file,
                                 const MapStoreOptions& options = {});
  MapStore(MapStore&& other) noexcept;
  MapStore& operator=(MapStore&& other) noexcept;
  MapStore(const MapStore&) = delete;
  MapStore& operator=(const MapStore&) = delete;
  ~MapStore();

  // One transaction: the session row, the floors, every node new or moved since the last save
  // (inserted or its pose updated),
  // the constraints of this mapper not stored yet (map_saved), and the folds they
  // complete.
  // And the mapper's tracking state (map_tracking), in the same transaction.
  Status save(const Mapper& mapper, int session, int64_t session_start_utime);
  // The tracking state alone, one small transaction (between saves: the robot moves on
  // between graph updates). Refused when the state names a node this store does not hold.
  Status saveTracking(const Mapper& mapper);
  Expected<MapSnapshot> load() const;
  // Rows of map_edges (a fold is one).
  Expected<int64_t> edgeRows() const { return queryInt("SELECT COUNT(*) FROM map_edges"); }
  // PRAGMA user_version: the schema's version (above).
  Expected<int64_t> schemaVersion() const { return queryInt("PRAGMA user_version"); }
  // PRAGMA integrity_check == "ok".
  Status integrityCheck() const;

 private:
  explicit MapStore(sqlite3* db, std::filesystem::path file, const MapStoreOptions& options)
      : db_(db), file_(std::move(file)), options_(options) {}
  Status exec(const char* sql) const;
  Expected<int64_t> queryInt(const char* sql, int64_t a = 0, int64_t b = 0) const;
  // Whether map_tracking has `column` (a store of an older schema lacks the later ones).
  Expected<bool> hasTrackingColumn(const char* column) const;
  // Folds the pair's rows into one when there are fold_after of them (inside save()).
  Status foldPair(const Mapper& mapper, int64_t i, int64_t j);
  // Replaces map_tracking's row by the mapper's state (or deletes it), inside a transaction.
  Status writeTracking(const Mapper& mapper);

  sqlite3* db_ = nullptr;
  std::filesystem::path file_;
  MapStoreOptions options_;
  int64_t last_edge_id_ = -1;  // highest edge id in the file
  // Each node's pose as this object last committed it (poseBlob), by id: save() writes the
  // rows that changed.
  std::vector<std::vector<double>> stored_poses_;
};

}  // namespace evermap::mapper
