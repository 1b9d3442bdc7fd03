#include "core/features/stereo_features.h"

#include <cmath>

#include "core/common/option_fields.h"

namespace evermap::core {

void StereoFeatureExtractor::Options::declareOptions(OptionList& o) {
  o.add("feature_levels", &feature_levels, "levels", "corners on pyramid levels [0, this)")
      .in(1, 6);
  o.add("pyramid_levels", &pyramid_levels, "levels",
        "pyramid levels (>= feature_levels; the top one serves rotation estimation)")
      .in(1, 8);
  o.nest("fast.", &fast);
  o.nest("stereo.", &stereo);
  o.nest("rgbd.", &rgbd);
}

Status StereoFeatureExtractor::Options::validate() const {
  if (Status s = checkOptionRanges(*this, "features."); !s) return s;
  if (pyramid_levels < feature_levels) {
    return makeError("stereo features: pyramid_levels ", pyramid_levels,
                     " is below feature_levels ", feature_levels);
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

template <typename Disparity>
Status StereoFeatureExtractor::extractWith(const StereoCamera& camera, int64_t utime,
                                           const cv::Mat& left, FeatureFrame* frame,
                                           Disparity disparity) {
  frame->utime = utime;
  frame->features.clear();
  frame->num_corners = 0;
  if (Status s = frame->left.build(left, options_.pyramid_levels); !s) return s;

  const std::vector<Keypoint> corners = detector_.detect(frame->left, options_.feature_levels);
  frame->num_corners = static_cast<int>(corners.size());
  frame->features.reserve(corners.size());
  for (const Keypoint& k : corners) {
    const float d = disparity(k);
    if (!std::isfinite(d)) continue;
    StereoFeature f;
    f.keypoint = k;
    f.uv = f.cornerUv();
    f.disparity = d;
    const auto p = camera.backProject(Eigen::Vector3d(f.uv.x(), f.uv.y(), d));
    if (!p) continue;
    f.point = *p;
    f.patch =
        patchDescriptor(frame->left.level(k.level), static_cast<int>(k.u), static_cast<int>(k.v));
    frame->features.push_back(f);
  }
  return Ok{};
}

Status StereoFeatureExtractor::extract(const StereoCamera& camera, int64_t utime,
                                       const cv::Mat& left, const cv::Mat& right,
                                       FeatureFrame* frame) {
  if (Status s = checkStereoImage(camera, left, "left image"); !s) return s;
  if (Status s = checkStereoImage(camera, right, "right image"); !s) return s;
  if (Status s = right_.build(right, options_.feature_levels); !s) return s;
  return extractWith(camera, utime, left, frame, [&](const Keypoint& k) {
    return depth_.disparity(camera, frame->left, right_, k);
  });
}

Status StereoFeatureExtractor::extractRgbd(const StereoCamera& camera, int64_t utime,
                                           const cv::Mat& gray, const cv::Mat& depth,
                                           double depth_scale_m, FeatureFrame* frame) {
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
  return extractWith(camera, utime, gray, frame, [&](const Keypoint& k) {
    const float s = ImagePyramid::scale(k.level);
    return rgbd_depth_.disparity(camera, depth, depth_scale_m, k.u * s, k.v * s);
  });
}

}  // namespace evermap::core
