#include "core/map/store_reader.h"

#include <cmath>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

#include "core/geometry/se2.h"
#include "core/map/store_codec.h"

namespace evermap::map {
namespace {

// The rows of a query of two columns, an int and what `second` reads, appended to `out`.
template <class T, class Second>
Status readPairs(const StoreFile& file, const char* sql, std::vector<std::pair<int, T>>& out,
                 Second second) {
  Statement st;
  if (!file.prepare(st, sql)) return file.sqliteError();
  while (sqlite3_step(st.s) == SQLITE_ROW)
    out.emplace_back(sqlite3_column_int(st.s, 0), second(st.s, 1));
  return Ok{};
}

Status readSessions(const StoreFile& file, MapSnapshot& out) {
  return readPairs(file, "SELECT session_id, start_utime FROM map_sessions ORDER BY session_id",
                   out.sessions, sqlite3_column_int64);
}

Status readFloors(const StoreFile& file, MapSnapshot& out) {
  return readPairs(file, "SELECT floor_index, height_m FROM map_floors ORDER BY floor_index",
                   out.floors, sqlite3_column_double);
}

Status readNodes(const StoreFile& file, MapSnapshot& out) {
  const std::string name = file.path().string();
  Statement st;
  if (!file.prepare(st,
                    "SELECT node_id, session_id, floor, keyframe_utime, pose FROM map_nodes "
                    "ORDER BY node_id"))
    return file.sqliteError();
  while (sqlite3_step(st.s) == SQLITE_ROW) {
    StoredNode n;
    n.node.id = sqlite3_column_int64(st.s, 0);
    n.node.session = sqlite3_column_int(st.s, 1);
    n.node.floor = sqlite3_column_int(st.s, 2);
    n.node.keyframe_utime = sqlite3_column_int64(st.s, 3);
    auto pose = poseFromBlob(sqlite3_column_blob(st.s, 4), sqlite3_column_bytes(st.s, 4),
                             name + ": node " + std::to_string(n.node.id));
    if (!pose) return pose.error();
    n.world_T_body = *pose;
    out.nodes.push_back(n);
  }
  return Ok{};
}

// After readNodes: each attitude belongs to a node read.
Status readAttitudes(const StoreFile& file, MapSnapshot& out) {
  const std::string name = file.path().string();
  Statement st;
  if (!file.prepare(
          st, "SELECT node_id, roll_rad, pitch_rad, covariance FROM map_attitude ORDER BY node_id"))
    return file.sqliteError();
  while (sqlite3_step(st.s) == SQLITE_ROW) {
    const int64_t id = sqlite3_column_int64(st.s, 0);
    const std::string what = name + ": attitude of node " + std::to_string(id);
    if (id < 0 || id >= static_cast<int64_t>(out.nodes.size()) ||
        out.nodes[static_cast<size_t>(id)].node.id != id)
      return makeError(what, ": no such node");
    auto cov = matrixColumn<2>(st.s, 3, what + ": covariance");
    if (!cov) return cov.error();
    NodeAttitude a;
    a.roll_rad = sqlite3_column_double(st.s, 1);
    a.pitch_rad = sqlite3_column_double(st.s, 2);
    a.covariance = *cov;
    out.nodes[static_cast<size_t>(id)].node.attitude = a;
  }
  return Ok{};
}

Status readEdges(const StoreFile& file, MapSnapshot& out) {
  const std::string name = file.path().string();
  Statement st;
  if (!file.prepare(
          st,
          "SELECT e.edge_id, e.from_node, e.to_node, e.kind, e.accepted, e.utime, e.pose, "
          "e.covariance,"
          " COALESCE(f.members, 0), COALESCE(f.rejected, 0)"
          " FROM map_edges e LEFT JOIN map_folds f ON f.edge_id = e.edge_id ORDER BY e.edge_id"))
    return file.sqliteError();
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
    auto cov = matrixColumn<6>(st.s, 7, what + ": covariance");
    if (!cov) return cov.error();
    e.constraint.from_T_to.covariance = *cov;
    e.folded = sqlite3_column_int64(st.s, 8);
    e.folded_rejected = sqlite3_column_int64(st.s, 9);
    out.edges.push_back(e);
  }
  return Ok{};
}

// map_tracking's odometry columns (8-12), when not NULL.
Expected<std::optional<OdometryAnchor>> odometryColumns(sqlite3_stmt* st, const std::string& what) {
  if (sqlite3_column_type(st, 8) == SQLITE_NULL) return std::optional<OdometryAnchor>();
  OdometryAnchor a;
  a.pose.epoch = sqlite3_column_int64(st, 8);
  a.pose.utime = sqlite3_column_int64(st, 9);
  auto pose =
      poseFromBlob(sqlite3_column_blob(st, 10), sqlite3_column_bytes(st, 10), what + " odometry");
  if (!pose) return pose.error();
  a.pose.odom_T_cam.mean = *pose;
  for (int col : {11, 12}) {
    auto c = matrixColumn<6>(st, col, what + ": odometry covariance");
    if (!c) return c.error();
    if (!c->allFinite()) return makeError(what, ": odometry covariance is not finite");
    (col == 11 ? a.pose.odom_T_cam.covariance : a.own_covariance) = *c;
  }
  return std::optional<OdometryAnchor>(a);
}

// map_tracking's wheel columns (13-16), when not NULL.
Expected<std::optional<messages::WheelOdometryPose>> wheelColumns(sqlite3_stmt* st,
                                                                  const std::string& what) {
  if (sqlite3_column_type(st, 13) == SQLITE_NULL)
    return std::optional<messages::WheelOdometryPose>();
  messages::WheelOdometryPose w;
  w.epoch = sqlite3_column_int64(st, 13);
  w.utime = sqlite3_column_int64(st, 14);
  double v[3];
  if (sqlite3_column_bytes(st, 15) != static_cast<int>(sizeof(v)) ||
      sqlite3_column_bytes(st, 16) != 9 * static_cast<int>(sizeof(double)))
    return makeError(what, ": wheel odometry blobs of ", sqlite3_column_bytes(st, 15), " and ",
                     sqlite3_column_bytes(st, 16), " bytes");
  std::memcpy(v, sqlite3_column_blob(st, 15), sizeof(v));
  auto c = matrixColumn<3>(st, 16, what);
  if (!c) return c.error();
  if (!std::isfinite(v[0]) || !std::isfinite(v[1]) || !std::isfinite(v[2]) || !c->allFinite())
    return makeError(what, ": wheel odometry pose is not finite");
  w.odom_T_body = core::SE2d(v[0], v[1], v[2]);
  w.covariance = *c;
  return std::optional<messages::WheelOdometryPose>(w);
}

// One row of map_tracking as read by readTracking's statement.
Expected<TrackingState> trackingRow(sqlite3_stmt* st, const std::string& what) {
  TrackingState t;
  t.utime = sqlite3_column_int64(st, 0);
  t.session = sqlite3_column_int(st, 1);
  t.session_start_utime = sqlite3_column_int64(st, 2);
  t.active_node = sqlite3_column_int64(st, 3);
  t.floor = sqlite3_column_int(st, 4);
  t.in_elevator = sqlite3_column_int(st, 5) != 0;
  auto pose = poseFromBlob(sqlite3_column_blob(st, 6), sqlite3_column_bytes(st, 6), what);
  if (!pose) return pose.error();
  t.active_T_body.mean = *pose;
  auto cov = matrixColumn<6>(st, 7, what + ": covariance");
  if (!cov) return cov.error();
  if (!cov->allFinite()) return makeError(what, ": covariance is not finite");
  t.active_T_body.covariance = *cov;
  auto odometry = odometryColumns(st, what);
  if (!odometry) return odometry.error();
  t.odometry = *odometry;
  auto wheel = wheelColumns(st, what);
  if (!wheel) return wheel.error();
  t.wheel = *wheel;
  return t;
}

// After readNodes: each footprint belongs to a node read. A store older than version 4 has none.
Status readFootprints(const StoreFile& file, MapSnapshot& out) {
  auto has_table = file.hasTable("map_footprints");
  if (!has_table) return has_table.error();
  if (!*has_table) return Ok{};
  Statement st;
  if (!file.prepare(st,
                    "SELECT footprint_id, node_id, session_id, x, y, theta FROM map_footprints "
                    "ORDER BY footprint_id"))
    return file.sqliteError();
  while (sqlite3_step(st.s) == SQLITE_ROW) {
    const int64_t id = sqlite3_column_int64(st.s, 0);
    const int64_t node = sqlite3_column_int64(st.s, 1);
    const int session = sqlite3_column_int(st.s, 2);
    const double x = sqlite3_column_double(st.s, 3), y = sqlite3_column_double(st.s, 4),
                 theta = sqlite3_column_double(st.s, 5);
    const std::string what = file.path().string() + ": footprint " + std::to_string(id);
    if (id != static_cast<int64_t>(out.footprints.size()))
      return makeError(what, ": footprints are not numbered in order");
    if (node < 0 || node >= static_cast<int64_t>(out.nodes.size()))
      return makeError(what, ": no such node ", node);
    if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(theta))
      return makeError(what, ": not a finite pose");
    out.footprints.push_back(Footprint{node, core::fromPlanar(core::SE2d(x, y, theta)), session});
  }
  return Ok{};
}

// The map_tracking row, if any. A version-0 store opened read-only has no map_tracking (no
// state); an older one lacks the later columns: read as NULL (no pose).
Status readTracking(const StoreFile& file, MapSnapshot& out) {
  auto has_tracking = file.hasTable("map_tracking");
  if (!has_tracking) return has_tracking.error();
  if (!*has_tracking) return Ok{};
  std::string sql =
      "SELECT utime, session_id, session_start_utime, active_node, floor, in_elevator, pose, "
      "covariance";
  for (const auto& [column, type] : kTrackingColumnsAdded) {
    auto has = file.hasTrackingColumn(column);
    if (!has) return has.error();
    sql += *has ? std::string(", ") + column : std::string(", NULL");
  }
  sql += " FROM map_tracking WHERE id = 0";
  Statement st;
  if (!file.prepare(st, sql.c_str())) return file.sqliteError();
  if (sqlite3_step(st.s) != SQLITE_ROW) return Ok{};
  auto t = trackingRow(st.s, file.path().string() + ": tracking state");
  if (!t) return t.error();
  out.tracking = *t;
  return Ok{};
}

}  // namespace

Expected<MapSnapshot> readMap(const StoreFile& file) {
  MapSnapshot out;
  for (auto read :
       {readSessions, readFloors, readNodes, readAttitudes, readEdges, readFootprints}) {
    if (Status s = read(file, out); !s) return s.error();
  }
  auto saved = file.queryInt("SELECT COALESCE(MAX(session_id), -1) FROM map_saved");
  if (!saved) return saved.error();
  out.max_saved_mapper = static_cast<int>(*saved);
  if (Status s = readTracking(file, out); !s) return s.error();
  return out;
}

}  // namespace evermap::map
