#include "mapper-proc/map_store.h"

#include <algorithm>
#include <optional>
#include <string>
#include <utility>

#include "core/geometry/se2.h"
#include "core/map/store_codec.h"
#include "mapper-proc/mapper.h"

namespace evermap::mapper {
namespace {

using map::bindMatrix;
using map::bindPose;
using map::poseBlob;
using map::Statement;

// The pair's accepted constraints, merged, when its rows are its own constraints alone: a pair
// that holds a merged node's constraints (constraint_set.h) is not this pair of rows alone (its
// merged estimate would count those rows twice), and one the mapper does not hold has nothing
// to fold. Their rows stay as they are.
const ConstraintSet::Pair* foldablePair(const Mapper& mapper, int64_t i, int64_t j) {
  const auto pair = mapper.constraints().pairs().find({i, j});
  if (pair == mapper.constraints().pairs().end()) return nullptr;
  const auto& all = mapper.constraints().all();
  for (size_t k : pair->second.members)
    if (all[k].from != i || all[k].to != j) return nullptr;
  return &pair->second;
}

}  // namespace

Expected<MapStore> MapStore::open(const std::filesystem::path& file,
                                  const MapStoreOptions& options) {
  if (options.fold_after < 0 || options.fold_after == 1)
    return makeError(file.string(), ": fold_after must be 0 (never) or >= 2");
  auto opened = map::StoreFile::open(file, options.read_only);
  if (!opened) return opened.error();
  auto last_edge_id = opened->lastEdgeId();
  if (!last_edge_id) return last_edge_id.error();
  return MapStore(std::move(*opened), options, *last_edge_id);
}

Status MapStore::save(const Mapper& mapper, int session, int64_t session_start_utime) {
  if (file_.readOnly()) return makeError(file_.path().string(), ": opened read-only, not saved");
  if (Status s = file_.exec("BEGIN IMMEDIATE"); !s) return s;
  const int64_t last_edge_before = last_edge_id_;
  PoseRows written;
  Status s = writeUpdate(mapper, session, session_start_utime, written);
  if (s) s = file_.exec("COMMIT");
  if (!s) {
    (void)file_.exec("ROLLBACK");
    last_edge_id_ = last_edge_before;
    return s;
  }
  // The cache takes the rows written only now that the transaction committed.
  stored_footprints_ = mapper.footprints().size();
  for (auto& [k, pose] : written) {
    if (k >= stored_poses_.size()) stored_poses_.resize(k + 1);
    stored_poses_[k] = std::move(pose);
  }
  // Free pages (folded rows, rewritten poses) leave the file, so its size is the map's.
  (void)file_.exec("PRAGMA incremental_vacuum");
  // Copy the committed pages into the file and empty the log, so the store on disk is the
  // map and not the history of its transactions (SQLite's automatic checkpoint keeps the
  // log's size, up to 4 MB here). A reader holding the log makes it a no-op until the next
  // save (SQLITE_BUSY): the commit above stands either way.
  (void)sqlite3_wal_checkpoint_v2(file_.db(), nullptr, SQLITE_CHECKPOINT_TRUNCATE, nullptr,
                                  nullptr);
  return Ok{};
}

Status MapStore::writeUpdate(const Mapper& mapper, int session, int64_t session_start_utime,
                             PoseRows& written) {
  if (Status s = writeSession(session, session_start_utime); !s) return s;
  if (Status s = writeFloors(mapper); !s) return s;
  if (Status s = writeNodes(mapper, written); !s) return s;
  NodePairs touched;
  if (Status s = writeConstraints(mapper, touched); !s) return s;
  if (Status s = markSaved(mapper); !s) return s;
  if (Status s = writeTracking(mapper); !s) return s;
  if (Status s = writeFootprints(mapper); !s) return s;
  if (options_.fold_after == 0) return Ok{};
  for (const auto& [i, j] : touched) {
    if (Status s = foldPair(mapper, i, j); !s) return s;
  }
  return Ok{};
}

Status MapStore::writeFootprints(const Mapper& mapper) {
  const std::vector<Footprint>& all = mapper.footprints();
  if (stored_footprints_ >= all.size()) return Ok{};
  Statement st;
  // A restored mapper holds the store's footprints first, under their ids: ignored.
  if (!file_.prepare(st, "INSERT OR IGNORE INTO map_footprints VALUES (?1, ?2, ?3, ?4, ?5, ?6)"))
    return file_.sqliteError("prepare");
  for (size_t k = stored_footprints_; k < all.size(); ++k) {
    const core::SE2d p = core::toPlanar(all[k].node_T_view);
    sqlite3_reset(st.s);
    sqlite3_bind_int64(st.s, 1, static_cast<int64_t>(k));
    sqlite3_bind_int64(st.s, 2, all[k].node);
    sqlite3_bind_int(st.s, 3, all[k].session);
    sqlite3_bind_double(st.s, 4, p.x());
    sqlite3_bind_double(st.s, 5, p.y());
    sqlite3_bind_double(st.s, 6, p.theta());
    if (sqlite3_step(st.s) != SQLITE_DONE) return file_.sqliteError("footprints");
  }
  return Ok{};
}

Status MapStore::writeSession(int session, int64_t session_start_utime) {
  Statement st;
  if (!file_.prepare(st, "INSERT OR IGNORE INTO map_sessions VALUES (?1, ?2)"))
    return file_.sqliteError("prepare");
  sqlite3_bind_int(st.s, 1, session);
  sqlite3_bind_int64(st.s, 2, session_start_utime);
  if (sqlite3_step(st.s) != SQLITE_DONE) return file_.sqliteError("sessions");
  return Ok{};
}

Status MapStore::writeFloors(const Mapper& mapper) {
  Statement st;
  if (!file_.prepare(st, "INSERT OR REPLACE INTO map_floors VALUES (?1, ?2)"))
    return file_.sqliteError("prepare");
  for (const auto& [index, height] : mapper.floors()) {
    sqlite3_reset(st.s);
    sqlite3_bind_int(st.s, 1, index);
    sqlite3_bind_double(st.s, 2, height);
    if (sqlite3_step(st.s) != SQLITE_DONE) return file_.sqliteError("floors");
  }
  return Ok{};
}

Status MapStore::writeNodes(const Mapper& mapper, PoseRows& written) {
  Statement nod, att;
  if (!file_.prepare(nod, "INSERT OR REPLACE INTO map_nodes VALUES (?1, ?2, ?3, ?4, ?5)") ||
      !file_.prepare(att, "INSERT OR IGNORE INTO map_attitude VALUES (?1, ?2, ?3, ?4)"))
    return file_.sqliteError("prepare");
  // Only the rows that changed: new nodes, and poses the solver moved since the last save
  // (most do not move at a step: the incremental solver's back substitution stops where the
  // change does).
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
    if (sqlite3_step(nod.s) != SQLITE_DONE) return file_.sqliteError("nodes");
    written.emplace_back(k, std::move(pose));
    if (!n.attitude || !is_new) continue;  // an attitude never changes: stored once
    sqlite3_reset(att.s);
    sqlite3_bind_int64(att.s, 1, n.id);
    sqlite3_bind_double(att.s, 2, n.attitude->roll_rad);
    sqlite3_bind_double(att.s, 3, n.attitude->pitch_rad);
    bindMatrix(att.s, 4, n.attitude->covariance);
    if (sqlite3_step(att.s) != SQLITE_DONE) return file_.sqliteError("attitude");
  }
  return Ok{};
}

Status MapStore::writeConstraints(const Mapper& mapper, NodePairs& touched) {
  Statement st;
  if (!file_.prepare(st, "INSERT INTO map_edges VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8)"))
    return file_.sqliteError("prepare");
  // This session's mapper's constraints from the first one not stored yet; the restored ones
  // (stats().restored_constraints) came from this file.
  auto saved =
      file_.queryInt("SELECT COALESCE(MAX(constraints), -1) FROM map_saved WHERE session_id = ?1",
                     mapper.firstSession());
  if (!saved) return file_.sqliteError("map_saved");
  const auto& all = mapper.constraints().all();
  const int64_t first_new = *saved >= 0 ? *saved : mapper.stats().restored_constraints;
  for (int64_t k = first_new; k < static_cast<int64_t>(all.size()); ++k) {
    const Constraint& c = all[static_cast<size_t>(k)];
    touched.emplace(std::min(c.from, c.to), std::max(c.from, c.to));
    sqlite3_reset(st.s);
    sqlite3_bind_int64(st.s, 1, ++last_edge_id_);
    sqlite3_bind_int64(st.s, 2, c.from);
    sqlite3_bind_int64(st.s, 3, c.to);
    sqlite3_bind_int(st.s, 4, static_cast<int>(c.kind));
    sqlite3_bind_int(st.s, 5, c.accepted ? 1 : 0);
    sqlite3_bind_int64(st.s, 6, c.utime);
    bindPose(st.s, 7, c.from_T_to.mean);
    bindMatrix(st.s, 8, c.from_T_to.covariance);
    if (sqlite3_step(st.s) != SQLITE_DONE) return file_.sqliteError("edges");
  }
  return Ok{};
}

Status MapStore::markSaved(const Mapper& mapper) {
  Statement st;
  if (!file_.prepare(st, "INSERT OR REPLACE INTO map_saved VALUES (?1, ?2)"))
    return file_.sqliteError("prepare");
  sqlite3_bind_int64(st.s, 1, mapper.firstSession());
  sqlite3_bind_int64(st.s, 2, static_cast<int64_t>(mapper.constraints().all().size()));
  if (sqlite3_step(st.s) != SQLITE_DONE) return file_.sqliteError("map_saved");
  return Ok{};
}

Status MapStore::writeTracking(const Mapper& mapper) {
  const std::optional<TrackingState> t = mapper.trackingState();
  if (!t) return file_.exec("DELETE FROM map_tracking");
  Statement st;
  if (!file_.prepare(
          st,
          "INSERT OR REPLACE INTO map_tracking (id, utime, session_id, session_start_utime, "
          "active_node,"
          " floor, in_elevator, pose, covariance, odom_epoch, odom_utime, odom_pose, "
          "odom_covariance,"
          " odom_own_covariance, wheel_epoch, wheel_utime, wheel_pose, wheel_covariance)"
          " VALUES (0, ?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14, ?15, ?16, "
          "?17)"))
    return file_.sqliteError("tracking");
  sqlite3_bind_int64(st.s, 1, t->utime);
  sqlite3_bind_int(st.s, 2, t->session);
  sqlite3_bind_int64(st.s, 3, t->session_start_utime);
  sqlite3_bind_int64(st.s, 4, t->active_node);
  sqlite3_bind_int(st.s, 5, t->floor);
  sqlite3_bind_int(st.s, 6, t->in_elevator ? 1 : 0);
  bindPose(st.s, 7, t->active_T_body.mean);
  bindMatrix(st.s, 8, t->active_T_body.covariance);
  // Unbound parameters are NULL: no odometry pose, no wheel pose.
  if (t->odometry) {
    const messages::OdometryPose& o = t->odometry->pose;
    sqlite3_bind_int64(st.s, 9, o.epoch);
    sqlite3_bind_int64(st.s, 10, o.utime);
    bindPose(st.s, 11, o.odom_T_cam.mean);
    bindMatrix(st.s, 12, o.odom_T_cam.covariance);
    bindMatrix(st.s, 13, t->odometry->own_covariance);
  }
  if (t->wheel) {
    const messages::WheelOdometryPose& w = *t->wheel;
    const double wheel_pose[3] = {w.odom_T_body.x(), w.odom_T_body.y(), w.odom_T_body.theta()};
    sqlite3_bind_int64(st.s, 14, w.epoch);
    sqlite3_bind_int64(st.s, 15, w.utime);
    sqlite3_bind_blob(st.s, 16, wheel_pose, sizeof(wheel_pose), SQLITE_TRANSIENT);
    bindMatrix(st.s, 17, w.covariance);
  }
  if (sqlite3_step(st.s) != SQLITE_DONE) return file_.sqliteError("tracking");
  return Ok{};
}

Status MapStore::saveTracking(const Mapper& mapper) {
  if (file_.readOnly()) return makeError(file_.path().string(), ": opened read-only, not saved");
  const std::optional<TrackingState> t = mapper.trackingState();
  // The row must name a node of this file (the node is saved with the map first).
  if (t) {
    auto held = file_.queryInt("SELECT COUNT(*) FROM map_nodes WHERE node_id = ?1", t->active_node);
    if (!held) return held.error();
    if (*held == 0)
      return makeError(file_.path().string(), ": tracking state names node ", t->active_node,
                       ", not stored yet");
  }
  if (Status s = file_.exec("BEGIN IMMEDIATE"); !s) return s;
  Status s = writeTracking(mapper);
  if (s) s = file_.exec("COMMIT");
  if (!s) (void)file_.exec("ROLLBACK");
  return s;
}

Status MapStore::foldPair(const Mapper& mapper, int64_t i, int64_t j) {
  const ConstraintSet::Pair* pair = foldablePair(mapper, i, j);
  if (!pair) return Ok{};
  auto count =
      file_.queryInt("SELECT COUNT(*) FROM map_edges WHERE from_node = ?1 AND to_node = ?2", i, j);
  if (!count) return count.error();
  if (*count < options_.fold_after) return Ok{};
  auto rows = pairRows(i, j);
  if (!rows) return rows.error();
  if (Status s = deletePairRows(i, j); !s) return s;
  return insertFold(i, j, *rows, pair->i_T_j);
}

Expected<MapStore::PairRows> MapStore::pairRows(int64_t i, int64_t j) const {
  // Folds count their members, single rows count one.
  const char* sql =
      "SELECT COALESCE(SUM(CASE WHEN f.edge_id IS NULL THEN e.accepted ELSE f.members END), 0),"
      " COALESCE(SUM(CASE WHEN f.edge_id IS NULL THEN 1 - e.accepted ELSE f.rejected END), 0),"
      " MIN(COALESCE(f.first_utime, e.utime)), MAX(e.utime), MIN(e.edge_id)"
      " FROM map_edges e LEFT JOIN map_folds f ON f.edge_id = e.edge_id WHERE e.from_node = ?1 AND "
      "e.to_node = ?2";
  PairRows rows;
  {
    Statement st;
    if (!file_.prepare(st, sql)) return file_.sqliteError("fold");
    sqlite3_bind_int64(st.s, 1, i);
    sqlite3_bind_int64(st.s, 2, j);
    if (sqlite3_step(st.s) != SQLITE_ROW) return file_.sqliteError("fold");
    rows.members = sqlite3_column_int64(st.s, 0);
    rows.rejected = sqlite3_column_int64(st.s, 1);
    rows.first_utime = sqlite3_column_int64(st.s, 2);
    rows.last_utime = sqlite3_column_int64(st.s, 3);
    rows.oldest_id = sqlite3_column_int64(st.s, 4);
  }
  // The pair's kind is its first constraint's (an odometry pair stays one when loops confirm it).
  auto first_kind = file_.queryInt(
      "SELECT kind FROM map_edges WHERE from_node = ?1 AND to_node = ?2 ORDER BY edge_id LIMIT 1",
      i, j);
  if (!first_kind) return first_kind.error();
  rows.kind = *first_kind;
  return rows;
}

Status MapStore::deletePairRows(int64_t i, int64_t j) {
  Statement del_folds, del_edges;
  if (!file_.prepare(del_folds,
                     "DELETE FROM map_folds WHERE edge_id IN"
                     " (SELECT edge_id FROM map_edges WHERE from_node = ?1 AND to_node = ?2)") ||
      !file_.prepare(del_edges, "DELETE FROM map_edges WHERE from_node = ?1 AND to_node = ?2"))
    return file_.sqliteError("fold");
  for (sqlite3_stmt* st : {del_folds.s, del_edges.s}) {
    sqlite3_bind_int64(st, 1, i);
    sqlite3_bind_int64(st, 2, j);
    if (sqlite3_step(st) != SQLITE_DONE) return file_.sqliteError("fold");
  }
  return Ok{};
}

// The merged estimate as one accepted row with the id of the pair's oldest row, and so in its
// place in the file: a row of the same size goes back where one was deleted, while a new id
// would append it to the end and leave the old row's page a hole for good (rowids only grow),
// so that the file would grow with every fold, i.e. with the visits (issue 22: +30 % over a
// simulated year while its rows grew 15 %). The pair's later constraints get larger ids
// (last_edge_id_), so a restore still adds the fold before them.
Status MapStore::insertFold(int64_t i, int64_t j, const PairRows& rows,
                            const core::UncertainPose& merged) {
  Statement edg, fold;
  if (!file_.prepare(edg, "INSERT INTO map_edges VALUES (?1, ?2, ?3, ?4, 1, ?5, ?6, ?7)") ||
      !file_.prepare(fold, "INSERT INTO map_folds VALUES (?1, ?2, ?3, ?4)"))
    return file_.sqliteError("fold");
  sqlite3_bind_int64(edg.s, 1, rows.oldest_id);
  sqlite3_bind_int64(edg.s, 2, i);
  sqlite3_bind_int64(edg.s, 3, j);
  sqlite3_bind_int64(edg.s, 4, rows.kind);
  sqlite3_bind_int64(edg.s, 5, rows.last_utime);
  bindPose(edg.s, 6, merged.mean);
  bindMatrix(edg.s, 7, merged.covariance);
  sqlite3_bind_int64(fold.s, 1, rows.oldest_id);
  sqlite3_bind_int64(fold.s, 2, rows.members);
  sqlite3_bind_int64(fold.s, 3, rows.rejected);
  sqlite3_bind_int64(fold.s, 4, rows.first_utime);
  if (sqlite3_step(edg.s) != SQLITE_DONE || sqlite3_step(fold.s) != SQLITE_DONE)
    return file_.sqliteError("fold");
  return Ok{};
}

}  // namespace evermap::mapper
