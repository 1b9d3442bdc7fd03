#include "core/features/stereo_features.h"

#include <cmath>

namespace evermap::core {

Status StereoFeatureExtractor::Options::validate() const {
  if (feature_levels < 1 || feature_levels > 6) {
    return makeError("stereo features: feature_levels ", feature_levels, " is not in [1, 6]");
  }
  if (pyramid_levels < feature_levels || pyramid_levels > 8) {
    return makeError("stereo features: pyramid_levels ", pyramid_levels,
                     " is not in [feature_levels, 8]");
  }
  if (fast.border_px < kPatchRadius + 1) {
    return makeError("stereo features: fast.border_px ", fast.border_px,
                     " leaves no room for the 9x9 patch (need >= ", kPatchRadius + 1, ")");
  }
  if (Status s = fast.validate(); !s) return s;
  if (Status s = rgbd.validate(); !s) return s;
  return stereo.validate();
}

Expected<StereoFeatureExtractor> StereoFeatureExtractor::create(const Options& options) {
  if (Status s = options.validate(); !s) return s.error();
  return StereoFeatureExtractor(options);
}

Status checkStereoImage(const StereoCamera& camera, const cv::Mat& image, const char* what) {
  if (image.empty()) return makeError(what, ": empty image");
  if (image.type() != CV_8UC1) return makeError(what, ": not an 8-bit gray image");
  if (image.cols != camera.width() || image.rows != camera.height()) {
    return makeError(what, ": ", image.cols, "x", image.rows, " but the camera is ", camera.width(),
                     "x", camera.height());
  }
  return Ok{};
}

namespace {

// The feature of corner k with level-0 disparity d (NaN: none); false when it has no depth.
bool makeFeature(const StereoCamera& camera, const ImagePyramid& left, const Keypoint& k, float d,
                 StereoFeature* f) {
  if (!std::isfinite(d)) return false;
  const float s = ImagePyramid::scale(k.level);
  f->keypoint = k;
  f->uv = Eigen::Vector2f(k.u * s, k.v * s);
  f->disparity = d;
  const auto p = camera.backProject(Eigen::Vector3d(f->uv.x(), f->uv.y(), d));
  if (!p) return false;
  f->point = *p;
  f->patch = patchDescriptor(left.level(k.level), static_cast<int>(k.u), static_cast<int>(k.v));
  return true;
}

}  // namespace

template <typename Disparity>
Status StereoFeatureExtractor::extractWith(const StereoCamera& camera, int64_t utime,
                                           FeatureFrame* frame, Disparity disparity,
                                           ParallelPair* pair) {
  frame->utime = utime;
  frame->features.clear();
  const std::vector<Keypoint> corners =
      detector_.detect(frame->left, options_.feature_levels, pair);
  frame->num_corners = static_cast<int>(corners.size());
  // Each corner on its own (even corners here, odd ones on the pair's worker), kept in the
  // corners' order: the same features as one pass.
  std::vector<StereoFeature> made(corners.size());
  std::vector<uint8_t> has(corners.size(), 0);
  auto make = [&](size_t first) {
    for (size_t i = first; i < corners.size(); i += 2) {
      has[i] = makeFeature(camera, frame->left, corners[i], disparity(corners[i]), &made[i]);
    }
  };
  runBoth(
      pair, [&] { make(0); }, [&] { make(1); });
  frame->features.reserve(corners.size());
  for (size_t i = 0; i < corners.size(); ++i) {
    if (has[i]) frame->features.push_back(made[i]);
  }
  return Ok{};
}

Status StereoFeatureExtractor::extract(const StereoCamera& camera, int64_t utime,
                                       const cv::Mat& left, const cv::Mat& right,
                                       FeatureFrame* frame, ParallelPair* pair) {
  if (Status s = checkStereoImage(camera, left, "left image"); !s) return s;
  if (Status s = checkStereoImage(camera, right, "right image"); !s) return s;
  frame->num_corners = 0;
  Status left_built = Ok{}, right_built = Ok{};
  runBoth(
      pair, [&] { left_built = frame->left.build(left, options_.pyramid_levels); },
      [&] { right_built = right_.build(right, options_.feature_levels); });
  if (!right_built) return right_built;
  if (!left_built) return left_built;
  return extractWith(
      camera, utime, frame,
      [&](const Keypoint& k) { return depth_.disparity(camera, frame->left, right_, k); }, pair);
}

Status StereoFeatureExtractor::extractRgbd(const StereoCamera& camera, int64_t utime,
                                           const cv::Mat& gray, const cv::Mat& depth,
                                           double depth_scale_m, FeatureFrame* frame,
                                           ParallelPair* pair) {
  if (Status s = checkStereoImage(camera, gray, "gray image"); !s) return s;
  if (depth.empty() || depth.type() != CV_16UC1) {
    return makeError("depth image: ", depth.empty() ? "empty" : "not 16-bit one-channel");
  }
  if (depth.cols != camera.width() || depth.rows != camera.height()) {
    return makeError("depth image: ", depth.cols, "x", depth.rows, " but the camera is ",
                     camera.width(), "x", camera.height());
  }
  if (!(depth_scale_m > 0.0) || !std::isfinite(depth_scale_m)) {
    return makeError("depth image: scale ", depth_scale_m, " m is not positive and finite");
  }
  frame->num_corners = 0;
  if (Status s = frame->left.build(gray, options_.pyramid_levels); !s) return s;
  return extractWith(
      camera, utime, frame,
      [&](const Keypoint& k) {
        const float s = ImagePyramid::scale(k.level);
        return rgbd_depth_.disparity(camera, depth, depth_scale_m, k.u * s, k.v * s);
      },
      pair);
}

}  // namespace evermap::core
