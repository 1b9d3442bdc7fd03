#include "tools/lcmlog/type_registry.h"

#include <algorithm>
#include <evermap/all_types.hpp>

#include "core/messages/convert.h"

namespace evermap::messages {
namespace {

struct Entry {
  TypeInfo info;
  bool (*decodes)(const void*, size_t);
};

template <typename T>
bool decodeAs(const void* data, size_t size) {
  return decodeLcm<T>(data, static_cast<int64_t>(size), T::getTypeName()).ok();
}

const std::vector<Entry>& entries() {
  static const std::vector<Entry> table = [] {
    std::vector<Entry> t;
#define EVERMAP_REGISTER_TYPE(type)                                                  \
  t.push_back(Entry{TypeInfo{#type, static_cast<int64_t>(evermap::type::getHash())}, \
                    &decodeAs<evermap::type>});
    EVERMAP_FOR_EACH_LCM_TYPE(EVERMAP_REGISTER_TYPE)
#undef EVERMAP_REGISTER_TYPE
    std::sort(t.begin(), t.end(),
              [](const Entry& a, const Entry& b) { return a.info.name < b.info.name; });
    return t;
  }();
  return table;
}

int64_t readFingerprint(const void* data) {
  const auto* b = static_cast<const uint8_t*>(data);
  uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v = (v << 8) | b[i];  // big-endian, as LCM encodes it
  return static_cast<int64_t>(v);
}

const Entry* find(const void* data, size_t size) {
  if (size < 8) return nullptr;
  const int64_t fp = readFingerprint(data);
  for (const Entry& e : entries()) {
    if (e.info.fingerprint == fp) return &e;
  }
  return nullptr;
}

}  // namespace

const std::vector<TypeInfo>& allTypes() {
  static const std::vector<TypeInfo> infos = [] {
    std::vector<TypeInfo> v;
    for (const Entry& e : entries()) v.push_back(e.info);
    return v;
  }();
  return infos;
}

std::optional<TypeInfo> identify(const void* data, size_t size) {
  const Entry* e = find(data, size);
  if (!e) return std::nullopt;
  return e->info;
}

bool decodesCleanly(const void* data, size_t size) {
  const Entry* e = find(data, size);
  return e && e->decodes(data, size);
}

}  // namespace evermap::messages
