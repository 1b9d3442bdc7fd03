#pragma once
// Sub-pixel alignment of a small image patch by Gauss-Newton on the sum of squared
// differences (Lucas & Kanade, IJCAI 1981; the inverse-compositional form of Baker &
// Matthews, "Lucas-Kanade 20 years on", IJCV 56(3), 2004, section 3): the template is the
// (2r+1)^2 patch of image `a` around an integer pixel; the warp is a translation (optionally
// along x only, for rectified stereo) plus a brightness offset. Because the warp is a pure
// translation, the bilinear weights are the same for every pixel of the patch.
//
// Used to refine the integer results of a discrete search: the disparity of a stereo match
// along its row, and the position of a feature matched between frames (FOVIS's sub-pixel
// refinement, Huang et al. 2011 section 3.4).

#include <optional>

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace evermap {
class OptionList;  // core/common/option_fields.h
}  // namespace evermap

namespace evermap::core {

struct PatchAlignmentOptions {
  int radius_px = 4;    // template (2r+1)^2
  bool x_only = false;  // rectified stereo: the match lies on the same row
  int max_iterations = 8;
  double max_shift_px = 1.5;  // from the start; farther means the discrete match was wrong
  double converged_px = 0.01;

  void declareOptions(OptionList& o);
};

// The position in `b` whose patch best matches the template of `a` at integer pixel
// (ua, va), starting from `start` in `b`; nullopt when a patch leaves an image, the template
// has no texture (singular normal equations) or the position moves more than max_shift_px.
std::optional<Eigen::Vector2f> alignPatch(const cv::Mat& a, int ua, int va, const cv::Mat& b,
                                          const Eigen::Vector2f& start,
                                          const PatchAlignmentOptions& options);

}  // namespace evermap::core
