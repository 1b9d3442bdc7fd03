#pragma once
// Checks shared by the image and message tests.

#include <string>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

namespace evermap::testing {

// The same size, type and pixels.
inline bool sameImage(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0.0;
}

// `result` (an Expected or Status) is an error whose message contains `needle`.
inline void expectError(const auto& result, const std::string& needle) {
  ASSERT_FALSE(result.ok()) << "accepted; wanted an error containing: " << needle;
  EXPECT_NE(result.error().message.find(needle), std::string::npos)
      << "got: " << result.error().message << "\nwanted: " << needle;
}

}  // namespace evermap::testing
