#pragma once
// A keyframe as loopclose-proc keeps it: what KEYFRAME (keyframe_t) carries, decoded and
// validated by core's one converter (messages::fromMsg in core/messages/keyframe_convert.h:
// the rectified camera and the features registration uses).

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

  int64_t utime() const { return features.utime; }  // microseconds: the keyframe's id
  size_t size() const { return features.size(); }
  // The descriptors in the form the vocabulary reads (a copy: a node's keyframe stays in
  // memory, its descriptors once).
  std::vector<bow::Descriptor> bowDescriptors() const;
};

// messages::fromMsg's checks (an empty keyframe, 0 features, is valid here: it is answered
// with a failure reason when used); the error names the keyframe and the field.
Expected<Keyframe> fromMsg(const evermap::keyframe_t& msg);
evermap::keyframe_t toMsg(const Keyframe& keyframe);

}  // namespace evermap::loopclose
