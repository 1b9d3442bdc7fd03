#pragma once
// How the map store's blobs hold poses and matrices (core/map/store_file.h: the schema): a
// pose is x y z qw qx qy qz (f64), a matrix its f64 in row-major order. Both ways, so that the
// writer and the reader agree by construction.

#include <sqlite3.h>

#include <cstring>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/common/expected.h"
#include "core/geometry/se3.h"

namespace evermap::map {

std::vector<double> poseBlob(const core::SE3d& p);
// A pose blob; the quaternion must be unit (1e-6). Errors start with `what`.
Expected<core::SE3d> poseFromBlob(const void* data, int bytes, const std::string& what);

// Binds parameter `index` of st to p's blob.
void bindPose(sqlite3_stmt* st, int index, const core::SE3d& p);
// Binds parameter `index` of st to m's blob (row-major).
template <typename Derived>
void bindMatrix(sqlite3_stmt* st, int index, const Eigen::MatrixBase<Derived>& m) {
  const Eigen::Matrix<double, Derived::RowsAtCompileTime, Derived::ColsAtCompileTime,
                      Eigen::RowMajor>
      row_major = m;
  sqlite3_bind_blob(st, index, row_major.data(),
                    static_cast<int>(row_major.size() * sizeof(double)), SQLITE_TRANSIENT);
}

// Column `col` of st's row as an N×N matrix (row-major blob); an error "<what> blob of <n>
// bytes" when it holds another size.
template <int N>
Expected<Eigen::Matrix<double, N, N>> matrixColumn(sqlite3_stmt* st, int col,
                                                   const std::string& what) {
  const int bytes = sqlite3_column_bytes(st, col);
  if (bytes != N * N * static_cast<int>(sizeof(double)))
    return makeError(what, " blob of ", bytes, " bytes");
  Eigen::Matrix<double, N, N, Eigen::RowMajor> m;
  std::memcpy(m.data(), sqlite3_column_blob(st, col), N * N * sizeof(double));
  return Eigen::Matrix<double, N, N>(m);
}

}  // namespace evermap::map
