#pragma once
// A keyframe as loopclose-proc keeps it: what KEYFRAME (keyframe_t) carries, decoded and
// validated by core's one converter (messages::fromMsg in core/messages/keyframe_convert.h:
// the rectified camera and the features registration uses), with its descriptors also in the
// bag-of-words form the vocabulary reads.

#include <cstdint>
#include <vector>

#include <evermap/keyframe_t.hpp>

#include "core/bow/descriptor.h"
#include "core/camera/stereo_camera.h"
#include "core/common/expected.h"
#include "core/registration/keyframe_features.h"

namespace evermap::loopclose {

struct Keyframe {
  core::StereoCamera camera;
  core::KeyframeFeatures features;
  std::vector<bow::Descriptor> descriptors;  // features.descriptors, for the vocabulary

  int64_t utime() const { return features.utime; }  // microseconds: the keyframe's id
  size_t size() const { return features.size(); }
};

// messages::fromMsg's checks (an empty keyframe, 0 features, is valid here: it is answered
// with a failure reason when used); the error names the keyframe and the field.
Expected<Keyframe> fromMsg(const evermap::keyframe_t& msg);
evermap::keyframe_t toMsg(const Keyframe& keyframe);

}  // namespace evermap::loopclose
