#pragma once
// Aligning an estimated trajectory to the ground truth before measuring it.
//
// Umeyama, "Least-squares estimation of transformation parameters between two point
// patterns", IEEE PAMI 13(4), 1991: the similarity (s, R, t) minimising
//   (1/n) Σ_i || y_i - (s R x_i + t) ||²
// in closed form from the SVD of the cross-covariance of the two point sets (eq. 38-42).
// SE(3) alignment fixes s = 1 (eq. 40-41 without eq. 42); Sim(3) also estimates the scale,
// needed for monocular estimates whose scale is unobservable. Only positions are used, as in
// the TUM and KITTI tools; orientations follow from the same transform. The fit itself is
// core/geometry/umeyama.h, which frame registration shares.

#include <string>
#include <string_view>
#include <vector>

#include "core/common/expected.h"
#include "core/geometry/se3.h"
#include "core/geometry/umeyama.h"

namespace evermap::eval {

// kFirstPose: the rigid transform that puts the first estimated pose on the first ground-truth
// pose (as evo's --align_origin) — the meaningful choice when the motion is too small or too
// straight for Umeyama to determine a rotation (e.g. a hovering vehicle).
enum class AlignmentMode { kNone, kSE3, kSim3, kFirstPose };

// "none", "se3", "sim3", "first".
const char* toString(AlignmentMode mode);
Expected<AlignmentMode> parseAlignmentMode(std::string_view name);

// A similarity transform gt_world_T_est_world: p_gt = scale * R * p_est + t.
using Similarity = core::Similarity;

struct AlignmentResult {
  AlignmentMode mode = AlignmentMode::kNone;
  Similarity gt_S_est;  // maps estimate-world points into the ground-truth world
  size_t pairs = 0;
  // False when the estimated positions are (nearly) collinear: the rotation about that line
  // is then not determined (Umeyama's rank condition fails); the error metrics are still the
  // minimum, but the reported rotation is one of many.
  bool rotation_unique = true;
};

// Least-squares dst ≈ s R src + t over corresponding points (Umeyama 1991). `with_scale`
// false fixes s = 1. Errors: sizes differ, fewer than 3 pairs, non-finite points, or (with
// scale) all source points equal.
Expected<AlignmentResult> umeyama(const std::vector<core::Vec3>& src,
                                  const std::vector<core::Vec3>& dst, bool with_scale);

// Aligns the positions of `est` onto those of `gt` (same length, paired by index). kNone
// returns the identity and needs only one pair.
Expected<AlignmentResult> alignTrajectories(const std::vector<core::SE3d>& gt,
                                            const std::vector<core::SE3d>& est, AlignmentMode mode);

}  // namespace evermap::eval
