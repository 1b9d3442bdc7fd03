#pragma once
// Conversions between core::KeyframeFeatures (with its rectified camera) and the LCM message
// keyframe_t (channel KEYFRAME), validated as convert.h does for the other types.
//
// keyframe_t carries fx, fy, cx, cy and the baseline but not the image size; the camera of a
// received keyframe is given the smallest size that holds its principal point at the centre
// and every keypoint (registration does not use the size).
// Nor does it carry the camera's disparity offset (right cx - left cx, StereoCamera): its
// disparities and points are the model's, corrected by the offset when they were measured, so
// the received camera has offset 0 and gives the same depths (keyframe_convert.cpp).

#include <cstdint>

#include <evermap/keyframe_t.hpp>

#include "core/camera/stereo_camera.h"
#include "core/common/expected.h"
#include "core/messages/convert.h"
#include "core/registration/keyframe_features.h"

namespace evermap::messages {

// Largest number of features a keyframe may claim (bounds what a malformed message costs).
inline constexpr int kMaxKeyframeFeatures = 100000;

struct KeyframeMsgContents {
  core::StereoCamera camera;
  core::KeyframeFeatures features;
};

evermap::keyframe_t toMsg(const core::StereoCamera& camera, const core::KeyframeFeatures& features);
// Errors name the field: a feature count outside [0, kMaxKeyframeFeatures], non-finite or
// non-positive intrinsics, inconsistent lengths, a feature that is not finite, a non-positive
// disparity or depth, a negative level.
Expected<KeyframeMsgContents> fromMsg(const evermap::keyframe_t& msg);

}  // namespace evermap::messages
