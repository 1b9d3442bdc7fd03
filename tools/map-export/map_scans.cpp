#include "tools/map-export/map_scans.h"

#include <cmath>
#include <utility>

#include <evermap/keyframe_t.hpp>

#include "core/messages/convert.h"
#include "core/messages/keyframe_convert.h"

namespace evermap::map_export {

namespace {

// A prepared statement finalised on every path.
struct Stmt {
  sqlite3_stmt* s = nullptr;
  ~Stmt() { sqlite3_finalize(s); }
};

Error sqlError(const std::filesystem::path& file, sqlite3* db) {
  return makeError(file.string(), ": ", db ? sqlite3_errmsg(db) : "out of memory");
}

bool finite(const core::SE3d& T) {
  return T.translation().allFinite() && T.quaternion().coeffs().allFinite();
}

}  // namespace

Expected<KeyframeReader> KeyframeReader::open(const std::filesystem::path& file) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(file, ec))
    return makeError(file.string(), ": no such place store (--places)");
  sqlite3* db = nullptr;
  if (sqlite3_open_v2(file.c_str(), &db, SQLITE_OPEN_READONLY, nullptr) != SQLITE_OK) {
    Error e = sqlError(file, db);
    sqlite3_close(db);
    return e;
  }
  KeyframeReader r(db, file);
  Stmt st;
  if (sqlite3_prepare_v2(db, "SELECT COUNT(*) FROM keyframes", -1, &st.s, nullptr) != SQLITE_OK)
    return makeError(file.string(), ": not a place store (no keyframes table: ", sqlite3_errmsg(db),
                     ")");
  return r;
}

KeyframeReader::KeyframeReader(KeyframeReader&& o) noexcept
    : db_(std::exchange(o.db_, nullptr)), file_(std::move(o.file_)) {}
KeyframeReader& KeyframeReader::operator=(KeyframeReader&& o) noexcept {
  if (this != &o) {
    sqlite3_close(db_);
    db_ = std::exchange(o.db_, nullptr);
    file_ = std::move(o.file_);
  }
  return *this;
}
KeyframeReader::~KeyframeReader() { sqlite3_close(db_); }

Expected<std::optional<std::vector<core::Vec3>>> KeyframeReader::points(int64_t utime) const {
  Stmt st;
  if (sqlite3_prepare_v2(db_, "SELECT message FROM keyframes WHERE utime = ?1", -1, &st.s,
                         nullptr) != SQLITE_OK)
    return sqlError(file_, db_);
  sqlite3_bind_int64(st.s, 1, utime);
  const int rc = sqlite3_step(st.s);
  if (rc == SQLITE_DONE) return std::optional<std::vector<core::Vec3>>();
  if (rc != SQLITE_ROW) return sqlError(file_, db_);
  const std::string what = file_.string() + ": keyframe " + std::to_string(utime);
  auto msg = messages::decodeLcm<evermap::keyframe_t>(sqlite3_column_blob(st.s, 0),
                                                      sqlite3_column_bytes(st.s, 0), what);
  if (!msg) return msg.error();
  auto contents = messages::fromMsg(*msg);
  if (!contents) return makeError(what, ": ", contents.error().message);
  std::vector<core::Vec3> out;
  out.reserve(contents->features.points.size());
  for (const Eigen::Vector3f& p : contents->features.points) out.push_back(p.cast<double>());
  return std::optional<std::vector<core::Vec3>>(std::move(out));
}

Expected<std::pair<int64_t, int64_t>> KeyframeReader::keyframeBytes() const {
  Stmt st;
  if (sqlite3_prepare_v2(db_, "SELECT COUNT(*), TOTAL(LENGTH(message)) FROM keyframes", -1, &st.s,
                         nullptr) != SQLITE_OK ||
      sqlite3_step(st.s) != SQLITE_ROW)
    return sqlError(file_, db_);
  return std::pair<int64_t, int64_t>(sqlite3_column_int64(st.s, 0),
                                     static_cast<int64_t>(sqlite3_column_double(st.s, 1)));
}

core::SE3d planTMap(UpAxis up) {
  if (up == UpAxis::kZ) return core::SE3d();
  // Rows: the plan's x, y, z in map coordinates (x, z forward-ish, -y up).
  Eigen::Matrix3d R;
  R << 1, 0, 0, 0, 0, 1, 0, -1, 0;
  return core::SE3d(Eigen::Quaterniond(R), core::Vec3::Zero());
}

ScanSet loadScans(const map::MapSnapshot& map, const KeyframeReader& keyframes,
                  const core::SE3d& body_T_cam, const core::SE3d& plan_T_map) {
  ScanSet out;
  auto drop = [&out](std::string message) {
    ++out.errors;
    out.messages.push_back(std::move(message));
  };
  for (const map::StoredNode& n : map.nodes) {
    const std::string name = "node " + std::to_string(n.node.id);
    if (!finite(n.world_T_body)) {
      drop(name + ": its pose is not finite");
      continue;
    }
    auto points = keyframes.points(n.node.keyframe_utime);
    if (!points) {
      drop(name + ": " + points.error().message);
      continue;
    }
    if (!*points) {
      drop(name + ": its keyframe " + std::to_string(n.node.keyframe_utime) +
           " is not in the place store");
      continue;
    }
    NodeScan s{n.node.id, n.node.session, n.node.floor, plan_T_map * n.world_T_body, {}};
    const core::SE3d world_T_cam = s.world_T_body * body_T_cam;
    s.scan.camera = world_T_cam.translation();
    s.scan.points.reserve((*points)->size());
    for (const core::Vec3& p : **points) s.scan.points.push_back(world_T_cam * p);
    out.nodes.push_back(std::move(s));
  }
  return out;
}

}  // namespace evermap::map_export
