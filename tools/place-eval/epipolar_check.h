#pragma once
// Geometric verification of a loop candidate between two monocular images: guided matches
// (guided_matching.h) must agree with one fundamental matrix, x_b^T F x_a = 0, estimated with
// RANSAC (cv::findFundamentalMat, 7-point minimal sets; Hartley & Zisserman, 2nd ed.,
// section 11.6). The candidate is accepted when enough matches are inliers. This is the
// check for image folders without depth; stereo keyframes are registered in 6-DOF instead.

#include <string>

#include "core/bow/bow_vector.h"
#include "tools/place-eval/guided_matching.h"
#include "tools/vocab-train/image_features.h"

namespace evermap::bow {

struct EpipolarCheckOptions {
  GuidedMatchOptions matching;
  // Largest distance of a point to its epipolar line for an inlier, pixels.
  double ransac_threshold_px = 2.0;
  // RANSAC confidence of having drawn one all-inlier sample.
  double confidence = 0.999;
  // Accepted when at least this many matches are inliers.
  int min_inliers = 30;

  std::string validate() const;  // empty when valid
};

struct EpipolarCheckResult {
  int matches = 0;  // guided matches tried
  int inliers = 0;  // consistent with the fundamental matrix (0 when fewer than 8 matches)
  bool accepted = false;
};

EpipolarCheckResult checkEpipolar(const ImageFeatures& a, const FeatureVector& direct_a,
                                  const ImageFeatures& b, const FeatureVector& direct_b,
                                  const EpipolarCheckOptions& options);

}  // namespace evermap::bow
