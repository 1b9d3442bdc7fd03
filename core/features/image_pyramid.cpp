#include "core/features/image_pyramid.h"

#include <cstdio>
#include <cstdlib>

#include <opencv2/imgproc.hpp>

namespace evermap::core {

ImagePyramid::ImagePyramid(const ImagePyramid& other) { *this = other; }

ImagePyramid& ImagePyramid::operator=(const ImagePyramid& other) {
  if (this != &other) {
    levels_.resize(other.levels_.size());
    for (size_t l = 0; l < levels_.size(); ++l) levels_[l] = other.levels_[l].clone();
  }
  return *this;
}

Status ImagePyramid::build(const cv::Mat& image, int num_levels) {
  if (image.empty() || image.type() != CV_8UC1) {
    return makeError("image pyramid: need a non-empty 8-bit gray image, got ",
                     image.empty() ? "an empty image" : "another type");
  }
  if (num_levels < 1 || num_levels > 8) {
    return makeError("image pyramid: num_levels ", num_levels, " is not in [1, 8]");
  }
  const int top = 1 << (num_levels - 1);
  if (image.cols / top < 8 || image.rows / top < 8) {
    return makeError("image pyramid: ", image.cols, "x", image.rows, " is too small for ",
                     num_levels, " levels");
  }
  levels_.resize(static_cast<size_t>(num_levels));
  // Level 0 is a copy (into the buffer of the last build): a pyramid kept as a reference
  // frame must not change when the caller reuses its image.
  image.copyTo(levels_[0]);
  for (int l = 1; l < num_levels; ++l) {
    cv::pyrDown(levels_[l - 1], levels_[l]);
  }
  return Ok{};
}

const cv::Mat& ImagePyramid::level(int l) const {
  if (l < 0 || l >= numLevels()) {
    std::fprintf(stderr, "evermap: ImagePyramid::level(%d) of a pyramid with %d levels\n", l,
                 numLevels());
    std::abort();
  }
  return levels_[static_cast<size_t>(l)];
}

}  // namespace evermap::core
