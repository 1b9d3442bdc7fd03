#include "core/map/store_codec.h"

#include <cmath>
#include <cstring>

namespace evermap::map {

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

void bindPose(sqlite3_stmt* st, int index, const core::SE3d& p) {
  const std::vector<double> blob = poseBlob(p);
  sqlite3_bind_blob(st, index, blob.data(), static_cast<int>(blob.size() * sizeof(double)),
                    SQLITE_TRANSIENT);
}

}  // namespace evermap::map
