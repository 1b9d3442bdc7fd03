#pragma once
// Every evermap LCM type by its fingerprint, so a program can name and decode any message it
// sees without knowing the channel (what lcm-spy does with the Java jar).

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace evermap::messages {

struct TypeInfo {
  std::string name;     // "imu_t"
  int64_t fingerprint;  // the 8-byte hash that starts every encoded message of this type
};

// All evermap types, sorted by name.
const std::vector<TypeInfo>& allTypes();

// The type whose fingerprint starts `data`, if any.
std::optional<TypeInfo> identify(const void* data, size_t size);

// Decodes `data` fully as the type it announces; false when unknown, short, malformed or with
// trailing bytes.
bool decodesCleanly(const void* data, size_t size);

}  // namespace evermap::messages
