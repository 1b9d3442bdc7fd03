#pragma once
// The least-squares similarity between two point sets.
//
// Umeyama, "Least-squares estimation of transformation parameters between two point
// patterns", IEEE PAMI 13(4), 1991: the similarity (s, R, t) minimising
//   (1/n) Σ_i || y_i - (s R x_i + t) ||²
// in closed form from the SVD of the cross-covariance of the two point sets (eq. 38-42).
// With the scale fixed to 1 it is the rigid fit (eq. 40-41 without eq. 42). Frame
// registration starts its motion estimate from it (core/registration); the evaluation aligns
// trajectories with it (tools/eval/alignment.h).

#include <cstddef>
#include <vector>

#include "core/common/expected.h"
#include "core/geometry/se3.h"

namespace evermap::core {

// A similarity transform a_S_b: p_a = scale * R * p_b + t.
struct Similarity {
  double scale = 1.0;
  SE3d rigid;  // R and t

  Vec3 operator*(const Vec3& p) const { return scale * (rigid.so3() * p) + rigid.translation(); }
  // Moves a whole pose into frame a: its orientation turns by R, its position maps as a point.
  SE3d operator*(const SE3d& pose) const {
    return SE3d(rigid.so3() * pose.so3(), *this * pose.translation());
  }
};

struct UmeyamaFit {
  Similarity dst_S_src;
  size_t pairs = 0;
  // False when the cross-covariance has rank < 2 (the points (nearly) collinear): the rotation
  // about that line is then not determined (Umeyama, after eq. 40), the fit is one of many.
  bool rotation_unique = true;
};

// Least-squares dst ≈ s R src + t over corresponding points. `with_scale` false fixes s = 1.
// Errors: sizes differ, fewer than 3 pairs, non-finite points, or (with scale) all source
// points equal. Their words are the evaluation's ("alignment: ... estimated ... ground-truth
// positions"), whose messages they were before this moved to core/; registration only tests
// ok().
Expected<UmeyamaFit> umeyama(const std::vector<Vec3>& src, const std::vector<Vec3>& dst,
                             bool with_scale);

}  // namespace evermap::core
