#pragma once
// Frame-to-frame matching for visual odometry (Huang et al. 2011, section 3.4): every feature
// of the reference frame with a 3-D point is projected into the current image with a predicted
// motion; the current features of the same pyramid level within search_radius_px (pixels of
// that level) of the prediction are compared by their 9x9 patch descriptors (sum of absolute
// differences); a pair is kept when each is the other's best (mutual check). The current
// position is then refined to sub-pixel precision by aligning the reference patch in the
// current image (core/features/patch_alignment.h).

#include <vector>

#include <Eigen/Core>

#include "core/camera/stereo_camera.h"
#include "core/common/expected.h"
#include "core/features/stereo_features.h"
#include "core/geometry/se3.h"

namespace evermap {
class OptionList;  // core/common/option_fields.h
}  // namespace evermap

namespace evermap::core {

struct WindowMatchOptions {
  int search_radius_px = 25;  // pixels of the feature's level
  bool mutual = true;
  // Largest mean absolute difference per pixel of the normalised patches (gray levels).
  double max_mean_abs_diff = 30.0;
  bool subpixel = true;
  double max_refinement_px = 1.5;  // pixels of the level; farther: the match is dropped

  Status validate() const;
  void declareOptions(OptionList& o);
};

struct WindowMatch {
  int ref = 0;  // index into ref.features
  int cur = 0;  // index into cur.features
  // The current feature in its image, level-0 pixels: sub-pixel when refined, else its corner
  // (as detected: before any correction of the frame's features, rolling_shutter_corrector.h).
  Eigen::Vector2f uv;
};

// `cur_T_ref` maps points of the reference camera into the current one (the prediction).
std::vector<WindowMatch> matchInWindow(const StereoCamera& camera, const FeatureFrame& ref,
                                       const FeatureFrame& cur, const SE3d& cur_T_ref,
                                       const WindowMatchOptions& options);

}  // namespace evermap::core
