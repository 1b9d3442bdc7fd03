#include "core/features/gray_image.h"

#include <opencv2/imgproc.hpp>

namespace evermap::core {

std::optional<cv::Mat> toGray(const cv::Mat& image) {
  if (image.channels() == 1) return image;
  cv::Mat gray;
  if (image.channels() == 3) {
    cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
  } else if (image.channels() == 4) {
    cv::cvtColor(image, gray, cv::COLOR_BGRA2GRAY);
  } else {
    return std::nullopt;
  }
  return gray;
}

}  // namespace evermap::core
