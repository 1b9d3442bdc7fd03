#pragma once
// An 8-bit image as one-channel gray, as the feature detectors take it.

#include <optional>

#include <opencv2/core.hpp>

namespace evermap::core {

// `image` itself when it has one channel; BGR and BGRA (OpenCV's channel order) converted to
// gray; nullopt for any other number of channels.
std::optional<cv::Mat> toGray(const cv::Mat& image);

}  // namespace evermap::core
