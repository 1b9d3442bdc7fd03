#include "loopclose-proc/keyframe.h"

#include <utility>

#include "core/messages/keyframe_convert.h"

namespace evermap::loopclose {

Expected<Keyframe> fromMsg(const evermap::keyframe_t& msg) {
  Expected<messages::KeyframeMsgContents> contents = messages::fromMsg(msg);
  if (!contents) return contents.error();
  Keyframe k{contents->camera, std::move(contents->features), {}};
  k.descriptors.reserve(k.features.descriptors.size());
  for (const core::OrbDescriptor& d : k.features.descriptors) {
    k.descriptors.push_back(bow::descriptorFromBytes(d.data()));
  }
  return k;
}

evermap::keyframe_t toMsg(const Keyframe& keyframe) {
  return messages::toMsg(keyframe.camera, keyframe.features);
}

}  // namespace evermap::loopclose
