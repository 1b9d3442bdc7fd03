#include "mapper-proc/map_store.h"

#include <cmath>
#include <cstring>
#include <set>
#include <string>
#include <utility>

namespace evermap::mapper {
namespace {

std::vector<double> poseBlob(const core::SE3d& p) {
  const auto& q = p.quaternion();
  return {
      p.translation().x(), p.translation().y(), p.translation().z(), q.w(), q.x(), q.y(), q.z()};
}

Expected<core::SE3d> poseFromBlob(const void* data, int bytes, const std::string& what) {
  if (bytes != 7 * static_cast<int>(sizeof(double)))
    return makeError(what, ": pose blob of ", bytes, " bytes");
  double v[7];
  std::memcpy(v, data, sizeof v);
  const Eigen::Quaterniond q(v[3], v[4], v[5], v[6]);
  if (!std::isfinite(q.norm()) || std::abs(q.norm() - 1.0) > 1e-6)
    return makeError(what, ": quaternion is not unit");
  return core::SE3d(q.normalized(), core::Vec3(v[0], v[1], v[2]));
}

// PRAGMA user_version of the schema this code writes (map_store.h: 0 before map_tracking).
constexpr int64_t kMapStoreSchemaVersion = 3;

// The map_tracking columns each version after 1 added (a store is migrated by adding them).
constexpr std::pair<const char*, const char*> kTrackingColumnsAdded[] = {
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

// Finalises a statement on every path.
struct Statement {
  sqlite3_stmt* s = nullptr;
  ~Statement() { sqlite3_finalize(s); }
};

}  // namespace

Expected<MapStore> MapStore::open(const std::filesystem::path& file,
                                  const MapStoreOptions& options) {
  if (options.fold_after < 0 || options.fold_after == 1)
    return makeError(file.string(), ": fold_after must be 0 (never) or >= 2");
  sqlite3* db = nullptr;
  const int flags =
      options.read_only ? SQLITE_OPEN_READONLY : SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE;
  if (sqlite3_open_v2(file.c_str(), &db, flags, nullptr) != SQLITE_OK) {
    std::string msg = db ? sqlite3_errmsg(db) : "out of memory";
    sqlite3_close(db);
    return makeError(file.string(), ": cannot open map store (", msg, ")");
  }
  MapStore store(db, file, options);
  const char* schema =
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
      // of later versions are added below (kTrackingColumnsAdded).
      "CREATE TABLE IF NOT EXISTS map_tracking (id INTEGER PRIMARY KEY CHECK (id = 0), utime "
      "INTEGER NOT NULL,"
      " session_id INTEGER NOT NULL, session_start_utime INTEGER NOT NULL, active_node INTEGER NOT "
      "NULL,"
      " floor INTEGER NOT NULL, in_elevator INTEGER NOT NULL, pose BLOB NOT NULL, covariance BLOB "
      "NOT NULL);";
  auto version = store.queryInt("PRAGMA user_version");
  if (!version) return version.error();
  if (*version > kMapStoreSchemaVersion)
    return makeError(file.string(), ": map store schema version ", *version,
                     ", newer than this program's ", kMapStoreSchemaVersion);
  if (!options.read_only) {
    if (Status s = store.exec(schema); !s) return s.error();
    // The columns of later versions the table lacks, added in one transaction (a kill leaves
    // the older version whole).
    std::string migrate;
    for (const auto& [column, type] : kTrackingColumnsAdded) {
      auto has = store.hasTrackingColumn(column);
      if (!has) return has.error();
      if (!*has)
        migrate += std::string("ALTER TABLE map_tracking ADD COLUMN ") + column + " " + type + ";";
    }
    if (!migrate.empty()) {
      if (Status s = store.exec(("BEGIN IMMEDIATE;" + migrate + "COMMIT;").c_str()); !s) {
        (void)store.exec("ROLLBACK");
        return s.error();
      }
    }
    if (*version < kMapStoreSchemaVersion) {
      const std::string set = "PRAGMA user_version=" + std::to_string(kMapStoreSchemaVersion);
      if (Status s = store.exec(set.c_str()); !s) return s.error();
    }
  }
  Statement st;
  if (sqlite3_prepare_v2(db, "SELECT COALESCE(MAX(edge_id), -1) FROM map_edges", -1, &st.s,
                         nullptr) != SQLITE_OK ||
      sqlite3_step(st.s) != SQLITE_ROW)
    return makeError(file.string(), ": not a map store (", sqlite3_errmsg(db), ")");
  store.last_edge_id_ = sqlite3_column_int64(st.s, 0);
  return store;
}

MapStore::MapStore(MapStore&& o) noexcept
    : db_(o.db_),
      file_(std::move(o.file_)),
      options_(o.options_),
      last_edge_id_(o.last_edge_id_),
      stored_poses_(std::move(o.stored_poses_)) {
  o.db_ = nullptr;
}
MapStore& MapStore::operator=(MapStore&& o) noexcept {
  if (this != &o) {
    sqlite3_close(db_);
    db_ = std::exchange(o.db_, nullptr);
    file_ = std::move(o.file_);
    options_ = o.options_;
    last_edge_id_ = o.last_edge_id_;
    stored_poses_ = std::move(o.stored_poses_);
  }
  return *this;
}
MapStore::~MapStore() { sqlite3_close(db_); }

Status MapStore::exec(const char* sql) const {
  char* err = nullptr;
  if (sqlite3_exec(db_, sql, nullptr, nullptr, &err) != SQLITE_OK) {
    std::string m = err ? err : "unknown error";
    sqlite3_free(err);
    return makeError(file_.string(), ": ", m);
  }
  return Ok{};
}

Status MapStore::save(const Mapper& mapper, int session, int64_t session_start_utime) {
  if (options_.read_only) return makeError(file_.string(), ": opened read-only, not saved");
  if (Status s = exec("BEGIN IMMEDIATE"); !s) return s;
  auto fail = [&](const char* what) -> Status {
    const std::string m = sqlite3_errmsg(db_);
    (void)exec("ROLLBACK");
    return makeError(file_.string(), ": ", what, ": ", m);
  };
  Statement ses, flo, nod, edg, att;
  if (sqlite3_prepare_v2(db_, "INSERT OR IGNORE INTO map_sessions VALUES (?1, ?2)", -1, &ses.s,
                         nullptr) ||
      sqlite3_prepare_v2(db_, "INSERT OR REPLACE INTO map_floors VALUES (?1, ?2)", -1, &flo.s,
                         nullptr) ||
      sqlite3_prepare_v2(db_, "INSERT OR REPLACE INTO map_nodes VALUES (?1, ?2, ?3, ?4, ?5)", -1,
                         &nod.s, nullptr) ||
      sqlite3_prepare_v2(db_, "INSERT INTO map_edges VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8)", -1,
                         &edg.s, nullptr) ||
      sqlite3_prepare_v2(db_, "INSERT OR IGNORE INTO map_attitude VALUES (?1, ?2, ?3, ?4)", -1,
                         &att.s, nullptr))
    return fail("prepare");
  sqlite3_bind_int(ses.s, 1, session);
  sqlite3_bind_int64(ses.s, 2, session_start_utime);
  if (sqlite3_step(ses.s) != SQLITE_DONE) return fail("sessions");
  for (const auto& [index, height] : mapper.floors()) {
    sqlite3_reset(flo.s);
    sqlite3_bind_int(flo.s, 1, index);
    sqlite3_bind_double(flo.s, 2, height);
    if (sqlite3_step(flo.s) != SQLITE_DONE) return fail("floors");
  }
  // Only the rows that changed: new nodes, and poses the solver moved since the last save
  // (most do not move at a step: the incremental solver's back substitution stops where the
  // change does). The cache takes them only once the transaction commits (see the end).
  std::vector<std::pair<size_t, std::vector<double>>> written;
  for (const MapperNode& n : mapper.nodes()) {
    std::vector<double> pose = poseBlob(mapper.nodePose(n.id));
    const auto k = static_cast<size_t>(n.id);
    const bool is_new = k >= stored_poses_.size();
    if (!is_new && stored_poses_[k] == pose) continue;
    sqlite3_reset(nod.s);
    sqlite3_bind_int64(nod.s, 1, n.id);
    sqlite3_bind_int(nod.s, 2, n.session);
    sqlite3_bind_int(nod.s, 3, n.floor);
    sqlite3_bind_int64(nod.s, 4, n.keyframe_utime);
    sqlite3_bind_blob(nod.s, 5, pose.data(), static_cast<int>(pose.size() * sizeof(double)),
                      SQLITE_TRANSIENT);
    if (sqlite3_step(nod.s) != SQLITE_DONE) return fail("nodes");
    written.emplace_back(k, std::move(pose));
    if (!n.attitude || !is_new) continue;  // an attitude never changes: stored once
    const Eigen::Matrix<double, 2, 2, Eigen::RowMajor> cov = n.attitude->covariance;
    sqlite3_reset(att.s);
    sqlite3_bind_int64(att.s, 1, n.id);
    sqlite3_bind_double(att.s, 2, n.attitude->roll_rad);
    sqlite3_bind_double(att.s, 3, n.attitude->pitch_rad);
    sqlite3_bind_blob(att.s, 4, cov.data(), 4 * sizeof(double), SQLITE_TRANSIENT);
    if (sqlite3_step(att.s) != SQLITE_DONE) return fail("attitude");
  }
  // This session's mapper's constraints from the first one not stored yet; the restored ones
  // (stats().restored_constraints) came from this file.
  const auto& all = mapper.constraints().all();
  auto saved =
      queryInt("SELECT COALESCE(MAX(constraints), -1) FROM map_saved WHERE session_id = ?1",
               mapper.firstSession());
  if (!saved) return fail("map_saved");
  const int64_t first_new = *saved >= 0 ? *saved : mapper.stats().restored_constraints;
  const int64_t last_edge_before = last_edge_id_;
  std::set<std::pair<int64_t, int64_t>> touched;
  for (int64_t k = first_new; k < static_cast<int64_t>(all.size()); ++k) {
    const Constraint& c = all[static_cast<size_t>(k)];
    const int64_t id = ++last_edge_id_;
    touched.emplace(std::min(c.from, c.to), std::max(c.from, c.to));
    const std::vector<double> pose = poseBlob(c.from_T_to.mean);
    Eigen::Matrix<double, 6, 6, Eigen::RowMajor> cov = c.from_T_to.covariance;
    sqlite3_reset(edg.s);
    sqlite3_bind_int64(edg.s, 1, id);
    sqlite3_bind_int64(edg.s, 2, c.from);
    sqlite3_bind_int64(edg.s, 3, c.to);
    sqlite3_bind_int(edg.s, 4, static_cast<int>(c.kind));
    sqlite3_bind_int(edg.s, 5, c.accepted ? 1 : 0);
    sqlite3_bind_int64(edg.s, 6, c.utime);
    sqlite3_bind_blob(edg.s, 7, pose.data(), static_cast<int>(pose.size() * sizeof(double)),
                      SQLITE_TRANSIENT);
    sqlite3_bind_blob(edg.s, 8, cov.data(), 36 * sizeof(double), SQLITE_TRANSIENT);
    if (sqlite3_step(edg.s) != SQLITE_DONE) {
      last_edge_id_ = last_edge_before;
      return fail("edges");
    }
  }
  {
    Statement sv;
    if (sqlite3_prepare_v2(db_, "INSERT OR REPLACE INTO map_saved VALUES (?1, ?2)", -1, &sv.s,
                           nullptr)) {
      last_edge_id_ = last_edge_before;
      return fail("prepare");
    }
    sqlite3_bind_int64(sv.s, 1, mapper.firstSession());
    sqlite3_bind_int64(sv.s, 2, static_cast<int64_t>(all.size()));
    if (sqlite3_step(sv.s) != SQLITE_DONE) {
      last_edge_id_ = last_edge_before;
      return fail("map_saved");
    }
  }
  if (Status s = writeTracking(mapper); !s) {
    (void)exec("ROLLBACK");
    last_edge_id_ = last_edge_before;
    return s;
  }
  if (options_.fold_after > 0) {
    for (const auto& [i, j] : touched) {
      if (Status s = foldPair(mapper, i, j); !s) {
        (void)exec("ROLLBACK");
        last_edge_id_ = last_edge_before;
        return s;
      }
    }
  }
  if (Status s = exec("COMMIT"); !s) {
    (void)exec("ROLLBACK");
    last_edge_id_ = last_edge_before;
    return s;
  }
  for (auto& [k, pose] : written) {
    if (k >= stored_poses_.size()) stored_poses_.resize(k + 1);
    stored_poses_[k] = std::move(pose);
  }
  // Free pages (folded rows, rewritten poses) leave the file, so its size is the map's.
  (void)exec("PRAGMA incremental_vacuum");
  // Copy the committed pages into the file and empty the log, so the store on disk is the
  // map and not the history of its transactions (SQLite's automatic checkpoint keeps the
  // log's size, up to 4 MB here). A reader holding the log makes it a no-op until the next
  // save (SQLITE_BUSY): the commit above stands either way.
  (void)sqlite3_wal_checkpoint_v2(db_, nullptr, SQLITE_CHECKPOINT_TRUNCATE, nullptr, nullptr);
  return Ok{};
}

Status MapStore::writeTracking(const Mapper& mapper) {
  const std::optional<TrackingState> t = mapper.trackingState();
  if (!t) return exec("DELETE FROM map_tracking");
  Statement st;
  if (sqlite3_prepare_v2(
          db_,
          "INSERT OR REPLACE INTO map_tracking (id, utime, session_id, session_start_utime, "
          "active_node,"
          " floor, in_elevator, pose, covariance, odom_epoch, odom_utime, odom_pose, "
          "odom_covariance,"
          " odom_own_covariance, wheel_epoch, wheel_utime, wheel_pose, wheel_covariance)"
          " VALUES (0, ?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14, ?15, ?16, ?17)",
          -1, &st.s, nullptr))
    return makeError(file_.string(), ": tracking: ", sqlite3_errmsg(db_));
  const std::vector<double> pose = poseBlob(t->active_T_body.mean);
  const Eigen::Matrix<double, 6, 6, Eigen::RowMajor> cov = t->active_T_body.covariance;
  sqlite3_bind_int64(st.s, 1, t->utime);
  sqlite3_bind_int(st.s, 2, t->session);
  sqlite3_bind_int64(st.s, 3, t->session_start_utime);
  sqlite3_bind_int64(st.s, 4, t->active_node);
  sqlite3_bind_int(st.s, 5, t->floor);
  sqlite3_bind_int(st.s, 6, t->in_elevator ? 1 : 0);
  sqlite3_bind_blob(st.s, 7, pose.data(), static_cast<int>(pose.size() * sizeof(double)),
                    SQLITE_TRANSIENT);
  sqlite3_bind_blob(st.s, 8, cov.data(), 36 * sizeof(double), SQLITE_TRANSIENT);
  if (t->odometry) {
    // Unbound parameters are NULL: no odometry pose.
    const messages::OdometryPose& o = t->odometry->pose;
    const std::vector<double> odom_pose = poseBlob(o.odom_T_cam.mean);
    const Eigen::Matrix<double, 6, 6, Eigen::RowMajor> odom_cov = o.odom_T_cam.covariance;
    const Eigen::Matrix<double, 6, 6, Eigen::RowMajor> own_cov = t->odometry->own_covariance;
    sqlite3_bind_int64(st.s, 9, o.epoch);
    sqlite3_bind_int64(st.s, 10, o.utime);
    sqlite3_bind_blob(st.s, 11, odom_pose.data(),
                      static_cast<int>(odom_pose.size() * sizeof(double)), SQLITE_TRANSIENT);
    sqlite3_bind_blob(st.s, 12, odom_cov.data(), 36 * sizeof(double), SQLITE_TRANSIENT);
    sqlite3_bind_blob(st.s, 13, own_cov.data(), 36 * sizeof(double), SQLITE_TRANSIENT);
  }
  if (t->wheel) {
    const messages::WheelOdometryPose& w = *t->wheel;
    const double wheel_pose[3] = {w.odom_T_body.x(), w.odom_T_body.y(), w.odom_T_body.theta()};
    const Eigen::Matrix<double, 3, 3, Eigen::RowMajor> wheel_cov = w.covariance;
    sqlite3_bind_int64(st.s, 14, w.epoch);
    sqlite3_bind_int64(st.s, 15, w.utime);
    sqlite3_bind_blob(st.s, 16, wheel_pose, sizeof(wheel_pose), SQLITE_TRANSIENT);
    sqlite3_bind_blob(st.s, 17, wheel_cov.data(), 9 * sizeof(double), SQLITE_TRANSIENT);
  }
  if (sqlite3_step(st.s) != SQLITE_DONE)
    return makeError(file_.string(), ": tracking: ", sqlite3_errmsg(db_));
  return Ok{};
}

Status MapStore::saveTracking(const Mapper& mapper) {
  if (options_.read_only) return makeError(file_.string(), ": opened read-only, not saved");
  const std::optional<TrackingState> t = mapper.trackingState();
  // The row must name a node of this file (the node is saved with the map first).
  if (t) {
    auto held = queryInt("SELECT COUNT(*) FROM map_nodes WHERE node_id = ?1", t->active_node);
    if (!held) return held.error();
    if (*held == 0)
      return makeError(file_.string(), ": tracking state names node ", t->active_node,
                       ", not stored yet");
  }
  if (Status s = exec("BEGIN IMMEDIATE"); !s) return s;
  if (Status s = writeTracking(mapper); !s) {
    (void)exec("ROLLBACK");
    return s;
  }
  if (Status s = exec("COMMIT"); !s) {
    (void)exec("ROLLBACK");
    return s;
  }
  return Ok{};
}

Expected<int64_t> MapStore::queryInt(const char* sql, int64_t a, int64_t b) const {
  Statement st;
  if (sqlite3_prepare_v2(db_, sql, -1, &st.s, nullptr) != SQLITE_OK)
    return makeError(file_.string(), ": ", sqlite3_errmsg(db_));
  sqlite3_bind_int64(st.s, 1, a);
  if (sqlite3_bind_parameter_count(st.s) >= 2) sqlite3_bind_int64(st.s, 2, b);
  if (sqlite3_step(st.s) != SQLITE_ROW) return makeError(file_.string(), ": ", sqlite3_errmsg(db_));
  return sqlite3_column_int64(st.s, 0);
}

Status MapStore::foldPair(const Mapper& mapper, int64_t i, int64_t j) {
  const auto pair = mapper.constraints().pairs().find({i, j});
  if (pair == mapper.constraints().pairs().end()) return Ok{};
  // A pair that holds a merged node's constraints (constraint_set.h) is not this pair of rows
  // alone: its merged estimate would count those rows twice. Its rows stay as they are.
  const auto& all = mapper.constraints().all();
  for (size_t k : pair->second.members)
    if (all[k].from != i || all[k].to != j) return Ok{};
  auto rows =
      queryInt("SELECT COUNT(*) FROM map_edges WHERE from_node = ?1 AND to_node = ?2", i, j);
  if (!rows) return rows.error();
  if (*rows < options_.fold_after) return Ok{};
  // What the rows stand for: folds count their members, single rows count one; and the
  // pair's oldest row id.
  const char* count_sql =
      "SELECT COALESCE(SUM(CASE WHEN f.edge_id IS NULL THEN e.accepted ELSE f.members END), 0),"
      " COALESCE(SUM(CASE WHEN f.edge_id IS NULL THEN 1 - e.accepted ELSE f.rejected END), 0),"
      " MIN(COALESCE(f.first_utime, e.utime)), MAX(e.utime), MIN(e.edge_id)"
      " FROM map_edges e LEFT JOIN map_folds f ON f.edge_id = e.edge_id WHERE e.from_node = ?1 AND "
      "e.to_node = ?2";
  int64_t members = 0, rejected = 0, first_utime = 0, last_utime = 0, oldest_id = 0, kind = 0;
  {
    Statement st;
    if (sqlite3_prepare_v2(db_, count_sql, -1, &st.s, nullptr) != SQLITE_OK)
      return makeError(file_.string(), ": fold: ", sqlite3_errmsg(db_));
    sqlite3_bind_int64(st.s, 1, i);
    sqlite3_bind_int64(st.s, 2, j);
    if (sqlite3_step(st.s) != SQLITE_ROW)
      return makeError(file_.string(), ": fold: ", sqlite3_errmsg(db_));
    members = sqlite3_column_int64(st.s, 0);
    rejected = sqlite3_column_int64(st.s, 1);
    first_utime = sqlite3_column_int64(st.s, 2);
    last_utime = sqlite3_column_int64(st.s, 3);
    oldest_id = sqlite3_column_int64(st.s, 4);
  }
  // The pair's kind is its first constraint's (an odometry pair stays one when loops confirm it).
  auto first_kind = queryInt(
      "SELECT kind FROM map_edges WHERE from_node = ?1 AND to_node = ?2 ORDER BY edge_id LIMIT 1",
      i, j);
  if (!first_kind) return first_kind.error();
  kind = *first_kind;
  {
    Statement del_folds, del_edges;
    if (sqlite3_prepare_v2(db_,
                           "DELETE FROM map_folds WHERE edge_id IN"
                           " (SELECT edge_id FROM map_edges WHERE from_node = ?1 AND to_node = ?2)",
                           -1, &del_folds.s, nullptr) ||
        sqlite3_prepare_v2(db_, "DELETE FROM map_edges WHERE from_node = ?1 AND to_node = ?2", -1,
                           &del_edges.s, nullptr))
      return makeError(file_.string(), ": fold: ", sqlite3_errmsg(db_));
    for (sqlite3_stmt* st : {del_folds.s, del_edges.s}) {
      sqlite3_bind_int64(st, 1, i);
      sqlite3_bind_int64(st, 2, j);
      if (sqlite3_step(st) != SQLITE_DONE)
        return makeError(file_.string(), ": fold: ", sqlite3_errmsg(db_));
    }
  }
  // The merged estimate as one accepted row with the id of the pair's oldest row, and so in
  // its place in the file: a row of the same size goes back where one was deleted, while a
  // new id would append it to the end and leave the old row's page a hole for good (rowids
  // only grow), so that the file would grow with every fold, i.e. with the visits (issue 22:
  // +30 % over a simulated year while its rows grew 15 %). The pair's later constraints get
  // larger ids (last_edge_id_), so a restore still adds the fold before them.
  const core::UncertainPose& merged = pair->second.i_T_j;
  const std::vector<double> pose = poseBlob(merged.mean);
  const Eigen::Matrix<double, 6, 6, Eigen::RowMajor> cov = merged.covariance;
  const int64_t id = oldest_id;
  Statement edg, fold;
  if (sqlite3_prepare_v2(db_, "INSERT INTO map_edges VALUES (?1, ?2, ?3, ?4, 1, ?5, ?6, ?7)", -1,
                         &edg.s, nullptr) ||
      sqlite3_prepare_v2(db_, "INSERT INTO map_folds VALUES (?1, ?2, ?3, ?4)", -1, &fold.s,
                         nullptr))
    return makeError(file_.string(), ": fold: ", sqlite3_errmsg(db_));
  sqlite3_bind_int64(edg.s, 1, id);
  sqlite3_bind_int64(edg.s, 2, i);
  sqlite3_bind_int64(edg.s, 3, j);
  sqlite3_bind_int64(edg.s, 4, kind);
  sqlite3_bind_int64(edg.s, 5, last_utime);
  sqlite3_bind_blob(edg.s, 6, pose.data(), static_cast<int>(pose.size() * sizeof(double)),
                    SQLITE_TRANSIENT);
  sqlite3_bind_blob(edg.s, 7, cov.data(), 36 * sizeof(double), SQLITE_TRANSIENT);
  sqlite3_bind_int64(fold.s, 1, id);
  sqlite3_bind_int64(fold.s, 2, members);
  sqlite3_bind_int64(fold.s, 3, rejected);
  sqlite3_bind_int64(fold.s, 4, first_utime);
  if (sqlite3_step(edg.s) != SQLITE_DONE || sqlite3_step(fold.s) != SQLITE_DONE)
    return makeError(file_.string(), ": fold: ", sqlite3_errmsg(db_));
  return Ok{};
}

Expected<MapSnapshot> MapStore::load() const {
  MapSnapshot out;
  const std::string name = file_.string();
  {
    Statement st;
    if (sqlite3_prepare_v2(db_,
                           "SELECT session_id, start_utime FROM map_sessions ORDER BY session_id",
                           -1, &st.s, nullptr))
      return makeError(name, ": ", sqlite3_errmsg(db_));
    while (sqlite3_step(st.s) == SQLITE_ROW)
      out.sessions.emplace_back(sqlite3_column_int(st.s, 0), sqlite3_column_int64(st.s, 1));
  }
  {
    Statement st;
    if (sqlite3_prepare_v2(db_, "SELECT floor_index, height_m FROM map_floors ORDER BY floor_index",
                           -1, &st.s, nullptr))
      return makeError(name, ": ", sqlite3_errmsg(db_));
    while (sqlite3_step(st.s) == SQLITE_ROW)
      out.floors.emplace_back(sqlite3_column_int(st.s, 0), sqlite3_column_double(st.s, 1));
  }
  {
    Statement st;
    if (sqlite3_prepare_v2(db_,
                           "SELECT node_id, session_id, floor, keyframe_utime, pose FROM map_nodes "
                           "ORDER BY node_id",
                           -1, &st.s, nullptr))
      return makeError(name, ": ", sqlite3_errmsg(db_));
    while (sqlite3_step(st.s) == SQLITE_ROW) {
      StoredNode n;
      n.node = MapperNode{sqlite3_column_int64(st.s, 0), sqlite3_column_int64(st.s, 3),
                          sqlite3_column_int(st.s, 2), sqlite3_column_int(st.s, 1), std::nullopt};
      auto pose = poseFromBlob(sqlite3_column_blob(st.s, 4), sqlite3_column_bytes(st.s, 4),
                               name + ": node " + std::to_string(n.node.id));
      if (!pose) return pose.error();
      n.world_T_body = *pose;
      out.nodes.push_back(n);
    }
  }
  {
    Statement st;
    if (sqlite3_prepare_v2(
            db_,
            "SELECT node_id, roll_rad, pitch_rad, covariance FROM map_attitude ORDER BY node_id",
            -1, &st.s, nullptr))
      return makeError(name, ": ", sqlite3_errmsg(db_));
    while (sqlite3_step(st.s) == SQLITE_ROW) {
      const int64_t id = sqlite3_column_int64(st.s, 0);
      const std::string what = name + ": attitude of node " + std::to_string(id);
      if (id < 0 || id >= static_cast<int64_t>(out.nodes.size()) ||
          out.nodes[static_cast<size_t>(id)].node.id != id)
        return makeError(what, ": no such node");
      if (sqlite3_column_bytes(st.s, 3) != 4 * static_cast<int>(sizeof(double)))
        return makeError(what, ": covariance blob of ", sqlite3_column_bytes(st.s, 3), " bytes");
      NodeAttitude a;
      a.roll_rad = sqlite3_column_double(st.s, 1);
      a.pitch_rad = sqlite3_column_double(st.s, 2);
      Eigen::Matrix<double, 2, 2, Eigen::RowMajor> cov;
      std::memcpy(cov.data(), sqlite3_column_blob(st.s, 3), 4 * sizeof(double));
      a.covariance = cov;
      out.nodes[static_cast<size_t>(id)].node.attitude = a;
    }
  }
  {
    Statement st;
    if (sqlite3_prepare_v2(
            db_,
            "SELECT e.edge_id, e.from_node, e.to_node, e.kind, e.accepted, e.utime, e.pose, "
            "e.covariance,"
            " COALESCE(f.members, 0), COALESCE(f.rejected, 0)"
            " FROM map_edges e LEFT JOIN map_folds f ON f.edge_id = e.edge_id ORDER BY e.edge_id",
            -1, &st.s, nullptr))
      return makeError(name, ": ", sqlite3_errmsg(db_));
    while (sqlite3_step(st.s) == SQLITE_ROW) {
      StoredEdge e;
      e.edge_id = sqlite3_column_int64(st.s, 0);
      const std::string what = name + ": edge " + std::to_string(e.edge_id);
      e.constraint.from = sqlite3_column_int64(st.s, 1);
      e.constraint.to = sqlite3_column_int64(st.s, 2);
      const int kind = sqlite3_column_int(st.s, 3);
      if (kind != 0 && kind != 1) return makeError(what, ": kind ", kind);
      e.constraint.kind = static_cast<ConstraintKind>(kind);
      e.constraint.accepted = sqlite3_column_int(st.s, 4) != 0;
      e.constraint.utime = sqlite3_column_int64(st.s, 5);
      auto pose = poseFromBlob(sqlite3_column_blob(st.s, 6), sqlite3_column_bytes(st.s, 6), what);
      if (!pose) return pose.error();
      e.constraint.from_T_to.mean = *pose;
      if (sqlite3_column_bytes(st.s, 7) != 36 * static_cast<int>(sizeof(double)))
        return makeError(what, ": covariance blob of ", sqlite3_column_bytes(st.s, 7), " bytes");
      Eigen::Matrix<double, 6, 6, Eigen::RowMajor> cov;
      std::memcpy(cov.data(), sqlite3_column_blob(st.s, 7), 36 * sizeof(double));
      e.constraint.from_T_to.covariance = cov;
      e.folded = sqlite3_column_int64(st.s, 8);
      e.folded_rejected = sqlite3_column_int64(st.s, 9);
      out.edges.push_back(e);
    }
  }
  {
    auto saved = queryInt("SELECT COALESCE(MAX(session_id), -1) FROM map_saved");
    if (!saved) return saved.error();
    out.max_saved_mapper = static_cast<int>(*saved);
  }
  // A version-0 store opened read-only has no map_tracking: no state.
  auto has_tracking =
      queryInt("SELECT COUNT(*) FROM sqlite_master WHERE type = 'table' AND name = 'map_tracking'");
  if (!has_tracking) return has_tracking.error();
  if (*has_tracking > 0) {
    // An older store opened read-only lacks the later columns: read as NULL (no pose).
    std::string sql =
        "SELECT utime, session_id, session_start_utime, active_node, floor, in_elevator, pose, "
        "covariance";
    for (const auto& [column, type] : kTrackingColumnsAdded) {
      auto has = hasTrackingColumn(column);
      if (!has) return has.error();
      sql += *has ? std::string(", ") + column : std::string(", NULL");
    }
    sql += " FROM map_tracking WHERE id = 0";
    Statement st;
    if (sqlite3_prepare_v2(db_, sql.c_str(), -1, &st.s, nullptr))
      return makeError(name, ": ", sqlite3_errmsg(db_));
    if (sqlite3_step(st.s) == SQLITE_ROW) {
      const std::string what = name + ": tracking state";
      TrackingState t;
      t.utime = sqlite3_column_int64(st.s, 0);
      t.session = sqlite3_column_int(st.s, 1);
      t.session_start_utime = sqlite3_column_int64(st.s, 2);
      t.active_node = sqlite3_column_int64(st.s, 3);
      t.floor = sqlite3_column_int(st.s, 4);
      t.in_elevator = sqlite3_column_int(st.s, 5) != 0;
      auto pose = poseFromBlob(sqlite3_column_blob(st.s, 6), sqlite3_column_bytes(st.s, 6), what);
      if (!pose) return pose.error();
      t.active_T_body.mean = *pose;
      if (sqlite3_column_bytes(st.s, 7) != 36 * static_cast<int>(sizeof(double)))
        return makeError(what, ": covariance blob of ", sqlite3_column_bytes(st.s, 7), " bytes");
      Eigen::Matrix<double, 6, 6, Eigen::RowMajor> cov;
      std::memcpy(cov.data(), sqlite3_column_blob(st.s, 7), 36 * sizeof(double));
      if (!cov.allFinite()) return makeError(what, ": covariance is not finite");
      t.active_T_body.covariance = cov;
      if (sqlite3_column_type(st.s, 8) != SQLITE_NULL) {
        Tracker::OdometryAnchor a;
        a.pose.epoch = sqlite3_column_int64(st.s, 8);
        a.pose.utime = sqlite3_column_int64(st.s, 9);
        auto odom_pose = poseFromBlob(sqlite3_column_blob(st.s, 10), sqlite3_column_bytes(st.s, 10),
                                      what + " odometry");
        if (!odom_pose) return odom_pose.error();
        a.pose.odom_T_cam.mean = *odom_pose;
        for (int col : {11, 12}) {
          if (sqlite3_column_bytes(st.s, col) != 36 * static_cast<int>(sizeof(double)))
            return makeError(what, ": odometry covariance blob of ",
                             sqlite3_column_bytes(st.s, col), " bytes");
          Eigen::Matrix<double, 6, 6, Eigen::RowMajor> c;
          std::memcpy(c.data(), sqlite3_column_blob(st.s, col), 36 * sizeof(double));
          if (!c.allFinite()) return makeError(what, ": odometry covariance is not finite");
          (col == 11 ? a.pose.odom_T_cam.covariance : a.own_covariance) = c;
        }
        t.odometry = a;
      }
      if (sqlite3_column_type(st.s, 13) != SQLITE_NULL) {
        messages::WheelOdometryPose w;
        w.epoch = sqlite3_column_int64(st.s, 13);
        w.utime = sqlite3_column_int64(st.s, 14);
        double v[3];
        if (sqlite3_column_bytes(st.s, 15) != static_cast<int>(sizeof(v)) ||
            sqlite3_column_bytes(st.s, 16) != 9 * static_cast<int>(sizeof(double)))
          return makeError(what, ": wheel odometry blobs of ", sqlite3_column_bytes(st.s, 15),
                           " and ", sqlite3_column_bytes(st.s, 16), " bytes");
        std::memcpy(v, sqlite3_column_blob(st.s, 15), sizeof(v));
        Eigen::Matrix<double, 3, 3, Eigen::RowMajor> c;
        std::memcpy(c.data(), sqlite3_column_blob(st.s, 16), 9 * sizeof(double));
        if (!std::isfinite(v[0]) || !std::isfinite(v[1]) || !std::isfinite(v[2]) || !c.allFinite())
          return makeError(what, ": wheel odometry pose is not finite");
        w.odom_T_body = core::SE2d(v[0], v[1], v[2]);
        w.covariance = c;
        t.wheel = w;
      }
      out.tracking = t;
    }
  }
  return out;
}

Expected<bool> MapStore::hasTrackingColumn(const char* column) const {
  const std::string sql =
      std::string("SELECT COUNT(*) FROM pragma_table_info('map_tracking') WHERE name = '") +
      column + "'";
  auto count = queryInt(sql.c_str());
  if (!count) return count.error();
  return *count > 0;
}

Status MapStore::integrityCheck() const {
  Statement st;
  if (sqlite3_prepare_v2(db_, "PRAGMA integrity_check", -1, &st.s, nullptr) ||
      sqlite3_step(st.s) != SQLITE_ROW)
    return makeError(file_.string(), ": integrity_check failed to run");
  const char* r = reinterpret_cast<const char*>(sqlite3_column_text(st.s, 0));
  if (!r || std::string(r) != "ok")
    return makeError(file_.string(), ": integrity_check: ", r ? r : "(null)");
  return Ok{};
}

}  // namespace evermap::mapper
