#include "core/registration/window_matcher.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <numeric>

#include "core/common/option_fields.h"
#include "core/features/patch_alignment.h"

namespace evermap::core {

void WindowMatchOptions::declareOptions(OptionList& o) {
  o.add("search_radius_px", &search_radius_px, "px",
        "search window around the predicted position (pixels of the feature's level)")
      .min(1);
  o.add("mutual", &mutual, "keep only matches that are each other's best");
  o.add("max_mean_abs_diff", &max_mean_abs_diff, "gray levels",
        "largest mean absolute difference per pixel of the normalised patches")
      .above(0)
      .max(255);
  o.add("subpixel", &subpixel, "refine matches to sub-pixel");
  o.add("max_refinement_px", &max_refinement_px, "px",
        "a refinement moving farther drops the match (pixels of the level)")
      .positive();
}

Status WindowMatchOptions::validate() const { return checkOptionRanges(*this, "matching."); }

std::vector<WindowMatch> matchInWindow(const StereoCamera& camera, const FeatureFrame& ref,
                                       const FeatureFrame& cur, const SE3d& cur_T_ref,
                                       const WindowMatchOptions& options) {
  const auto& rf = ref.features;
  const auto& cf = cur.features;
  // A current feature's position in its level's pixels, as the frame's features have it (a
  // rolling shutter's correction applied: where the prediction puts it), and the current
  // features sorted by (level, v): the candidates of a window are a contiguous run of rows of
  // one level.
  auto at = [&](int idx) -> Eigen::Vector2f {
    const StereoFeature& c = cf[static_cast<size_t>(idx)];
    return c.uv / ImagePyramid::scale(c.keypoint.level);
  };
  std::vector<int> order(cf.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int a, int b) {
    const int la = cf[static_cast<size_t>(a)].keypoint.level;
    const int lb = cf[static_cast<size_t>(b)].keypoint.level;
    return la != lb ? la < lb : at(a).y() < at(b).y();
  });
  const int max_sad = static_cast<int>(options.max_mean_abs_diff * kPatchBytes);
  std::vector<int> best_cur(rf.size(), -1);
  std::vector<int> best_ref(cf.size(), -1), best_ref_sad(cf.size(), INT_MAX);
  const float radius = static_cast<float>(options.search_radius_px);
  const Mat3 R = cur_T_ref.rotationMatrix();
  const Vec3 t = cur_T_ref.translation();
  for (size_t i = 0; i < rf.size(); ++i) {
    const StereoFeature& f = rf[i];
    const auto uvd = camera.project(R * f.point + t);
    if (!uvd) continue;
    const int level = f.keypoint.level;
    const float s = ImagePyramid::scale(level);
    const float pu = static_cast<float>(uvd->x()) / s, pv = static_cast<float>(uvd->y()) / s;
    // First current feature of this level with v >= pv - radius.
    auto first = std::lower_bound(order.begin(), order.end(), 0, [&](int idx, int) {
      const int l = cf[static_cast<size_t>(idx)].keypoint.level;
      return l != level ? l < level : at(idx).y() < pv - radius;
    });
    int best = -1, best_sad = max_sad + 1;
    for (auto it = first; it != order.end(); ++it) {
      const StereoFeature& c = cf[static_cast<size_t>(*it)];
      const Eigen::Vector2f c_at = at(*it);
      if (c.keypoint.level != level || c_at.y() > pv + radius) break;
      if (std::abs(c_at.x() - pu) > radius) continue;
      const int sad = patchSad(f.patch, c.patch);
      if (sad < best_sad) {
        best_sad = sad;
        best = *it;
      }
      if (sad < best_ref_sad[static_cast<size_t>(*it)]) {
        best_ref_sad[static_cast<size_t>(*it)] = sad;
        best_ref[static_cast<size_t>(*it)] = static_cast<int>(i);
      }
    }
    best_cur[i] = best;
  }

  std::vector<WindowMatch> out;
  PatchAlignmentOptions align;
  align.radius_px = kPatchRadius;
  align.max_shift_px = options.max_refinement_px;
  for (size_t i = 0; i < rf.size(); ++i) {
    const int j = best_cur[i];
    if (j < 0) continue;
    if (options.mutual && best_ref[static_cast<size_t>(j)] != static_cast<int>(i)) continue;
    const StereoFeature& f = rf[i];
    const StereoFeature& c = cf[static_cast<size_t>(j)];
    WindowMatch m{static_cast<int>(i), j, c.cornerUv()};
    if (options.subpixel) {
      const int level = f.keypoint.level;
      const auto p = alignPatch(ref.left.level(level), static_cast<int>(f.keypoint.u),
                                static_cast<int>(f.keypoint.v), cur.left.level(level),
                                Eigen::Vector2f(c.keypoint.u, c.keypoint.v), align);
      if (!p) continue;
      m.uv = *p * ImagePyramid::scale(level);
    }
    out.push_back(m);
  }
  return out;
}

}  // namespace evermap::core
