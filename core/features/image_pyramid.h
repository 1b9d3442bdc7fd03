#pragma once
// A Gaussian image pyramid: level 0 is the image itself, level l+1 is level l smoothed by the
// 5x5 binomial kernel and subsampled by 2 (cv::pyrDown; Burt & Adelson, "The Laplacian
// pyramid as a compact image code", IEEE Trans. Communications 31(4), 1983).
//
// Pixel (u, v) of level l lies at (2^l u, 2^l v) in level 0: pyrDown keeps the even samples,
// so the grids share their origin (no half-pixel shift).

#include <vector>

#include <opencv2/core.hpp>

#include "core/common/expected.h"

namespace evermap::core {

class ImagePyramid {
 public:
  ImagePyramid() = default;
  // Copies are deep (cv::Mat alone would share pixels, and build() reuses its buffers).
  ImagePyramid(const ImagePyramid& other);
  ImagePyramid& operator=(const ImagePyramid& other);
  ImagePyramid(ImagePyramid&&) noexcept = default;
  ImagePyramid& operator=(ImagePyramid&&) noexcept = default;

  // Rebuilds the pyramid from `image` (CV_8UC1, non-empty), reusing this object's buffers.
  // Fails on an empty or non-gray image, and when `num_levels` is not in [1, 8] or the top
  // level would be smaller than 8x8 pixels.
  Status build(const cv::Mat& image, int num_levels);

  int numLevels() const { return static_cast<int>(levels_.size()); }
  // Precondition: 0 <= l < numLevels() (an always-on check aborts otherwise).
  const cv::Mat& level(int l) const;
  // Level-0 pixels per pixel of level l.
  static float scale(int l) { return static_cast<float>(1 << l); }

 private:
  std::vector<cv::Mat> levels_;
};

}  // namespace evermap::core
