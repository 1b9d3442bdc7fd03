#include "core/messages/keyframe_parts.h"

#include <algorithm>
#include <limits>

#include "core/messages/wire_check.h"

namespace evermap::messages {

int keyframePartCount(const evermap::keyframe_t& keyframe, int part_bytes) {
  const int64_t total = keyframe.getEncodedSize();
  if (part_bytes <= 0 || total <= 0) return 0;
  const int64_t count = (total + part_bytes - 1) / part_bytes;
  return count > std::numeric_limits<int16_t>::max() ? 0 : static_cast<int>(count);
}

std::vector<evermap::keyframe_part_t> splitKeyframe(const evermap::keyframe_t& keyframe,
                                                    int part_bytes) {
  const int count = keyframePartCount(keyframe, part_bytes);
  if (count == 0) return {};
  const int total = keyframe.getEncodedSize();
  std::vector<uint8_t> bytes(static_cast<size_t>(total));
  if (keyframe.encode(bytes.data(), 0, total) != total) return {};
  std::vector<evermap::keyframe_part_t> parts(static_cast<size_t>(count));
  for (int i = 0; i < count; ++i) {
    evermap::keyframe_part_t& p = parts[static_cast<size_t>(i)];
    p.utime = keyframe.utime;
    p.total_bytes = total;
    p.index = static_cast<int16_t>(i);
    p.count = static_cast<int16_t>(count);
    p.offset = i * part_bytes;
    p.size = std::min(part_bytes, total - p.offset);
    p.data.assign(bytes.begin() + p.offset, bytes.begin() + p.offset + p.size);
  }
  return parts;
}

namespace {

// What is wrong with a part on its own, or nothing.
std::optional<Error> partError(const evermap::keyframe_part_t& p) {
  const auto named = [&](const char* what) {
    return makeError("KEYFRAME_PART of keyframe ", p.utime, " part ", p.index, ": ", what);
  };
  if (p.total_bytes <= 0 || p.total_bytes > kMaxKeyframeBytes) {
    return named("total_bytes out of range");
  }
  if (p.count <= 0 || p.index < 0 || p.index >= p.count)
    return named("index or count out of range");
  if (p.size <= 0 || static_cast<size_t>(p.size) != p.data.size())
    return named("size is not that of data");
  if (p.offset < 0 || static_cast<int64_t>(p.offset) + p.size > p.total_bytes) {
    return named("data lies outside the keyframe");
  }
  return std::nullopt;
}

}  // namespace

Expected<std::optional<evermap::keyframe_t>> KeyframeAssembler::add(
    const evermap::keyframe_part_t& part) {
  if (auto e = partError(part)) return *e;
  const int64_t utime = part.utime;
  auto it = open_.find(utime);
  if (it != open_.end() &&
      (it->second.total_bytes != part.total_bytes || it->second.count != part.count)) {
    erase(utime);  // another layout: the keyframe was published again differently
    it = open_.end();
  }
  if (it != open_.end() && it->second.parts.count(part.index))
    return std::optional<evermap::keyframe_t>();
  if (bytes_held_ + part.size > max_bytes_) {
    return makeError("KEYFRAME_PART of keyframe ", utime, ": more than ", max_bytes_,
                     " bytes of parts held");
  }
  if (it == open_.end()) it = open_.emplace(utime, Open{part.total_bytes, part.count, {}}).first;
  it->second.parts.emplace(part.index, part);
  bytes_held_ += part.size;
  if (static_cast<int>(it->second.parts.size()) < it->second.count)
    return std::optional<evermap::keyframe_t>();
  Expected<evermap::keyframe_t> keyframe = join(utime, it->second);
  erase(utime);
  if (!keyframe) return keyframe.error();
  return std::optional<evermap::keyframe_t>(std::move(*keyframe));
}

Expected<evermap::keyframe_t> KeyframeAssembler::join(int64_t keyframe_utime,
                                                      const Open& open) const {
  std::vector<uint8_t> bytes;
  bytes.reserve(static_cast<size_t>(open.total_bytes));
  for (const auto& [index, p] : open.parts) {
    if (p.offset != static_cast<int32_t>(bytes.size())) {
      return makeError("KEYFRAME_PART of keyframe ", keyframe_utime, ": part ", index,
                       " does not follow the one before");
    }
    bytes.insert(bytes.end(), p.data.begin(), p.data.end());
  }
  // The wire check first: the decoder would allocate what the bytes claim (wire_check.h).
  evermap::keyframe_t keyframe;
  const Expected<int64_t> checked =
      checkWire<evermap::keyframe_t>(bytes.data(), static_cast<int64_t>(bytes.size()));
  if (!checked || *checked != open.total_bytes ||
      keyframe.decode(bytes.data(), 0, open.total_bytes) != open.total_bytes) {
    return makeError("KEYFRAME_PART of keyframe ", keyframe_utime,
                     ": the parts do not decode to a keyframe_t");
  }
  if (keyframe.utime != keyframe_utime) {
    return makeError("KEYFRAME_PART of keyframe ", keyframe_utime, ": the parts hold keyframe ",
                     keyframe.utime);
  }
  return keyframe;
}

std::vector<int16_t> KeyframeAssembler::missing(int64_t keyframe_utime) const {
  const auto it = open_.find(keyframe_utime);
  if (it == open_.end()) return {};
  std::vector<int16_t> out;
  for (int16_t i = 0; i < it->second.count; ++i) {
    if (!it->second.parts.count(i)) out.push_back(i);
  }
  return out;
}

void KeyframeAssembler::erase(int64_t keyframe_utime) {
  const auto it = open_.find(keyframe_utime);
  if (it == open_.end()) return;
  for (const auto& [index, p] : it->second.parts) bytes_held_ -= p.size;
  open_.erase(it);
}

}  // namespace evermap::messages
