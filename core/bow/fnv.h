#pragma once
// FNV-1a, 64 bit (Fowler, Noll, Vo): a small non-cryptographic hash used for the vocabulary
// fingerprint and the checksum of evermap's vocabulary files. Integers are hashed as their
// little-endian bytes, so the value does not depend on the host.

#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstring>

namespace evermap::bow {

class Fnv1a64 {
 public:
  void addBytes(const void* data, size_t size) {
    const auto* p = static_cast<const uint8_t*>(data);
    for (size_t i = 0; i < size; ++i) {
      h_ ^= p[i];
      h_ *= 0x100000001b3ull;
    }
  }
  void add(uint32_t v) { addLittleEndian(v, 4); }
  void add(int64_t v) { addLittleEndian(static_cast<uint64_t>(v), 8); }
  void add(double v) { addLittleEndian(std::bit_cast<uint64_t>(v), 8); }
  uint64_t value() const { return h_; }

 private:
  void addLittleEndian(uint64_t v, int bytes) {
    for (int i = 0; i < bytes; ++i) {
      const uint8_t b = static_cast<uint8_t>(v >> (8 * i));
      addBytes(&b, 1);
    }
  }
  uint64_t h_ = 0xcbf29ce484222325ull;
};

}  // namespace evermap::bow
