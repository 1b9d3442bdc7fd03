#include "loopclose-proc/keyframe.h"

#include <utility>

#include "core/messages/keyframe_convert.h"

namespace evermap::loopclose {

Expected<Keyframe> fromMsg(const evermap::keyframe_t& msg) {
  Expected<messages::KeyframeMsgContents> contents = messages::fromMsg(msg);
  if (!contents) return contents.error();
  return Keyframe{contents->camera, std::move(contents->features)};
}

std::vector<bow::Descriptor> Keyframe::bowDescriptors() const {
  std::vector<bow::Descriptor> out;
  out.reserve(features.descriptors.size());
  for (const core::OrbDescriptor& d : features.descriptors) {
    out.push_back(bow::descriptorFromBytes(d.data()));
  }
  return out;
}

evermap::keyframe_t toMsg(const Keyframe& keyframe) {
  return messages::toMsg(keyframe.camera, keyframe.features);
}

}  // namespace evermap::loopclose
