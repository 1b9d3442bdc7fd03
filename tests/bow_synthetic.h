#pragma once
// Synthetic binary descriptors for the core/bow tests: random 256-bit strings and noisy copies.

#include <vector>

#include "core/bow/descriptor.h"
#include "tools/vocab-train/kmajority.h"

namespace evermap::bow::testing {

inline Descriptor randomDescriptor(SplitMix64& rng) {
  Descriptor d;
  for (int w = 0; w < 4; ++w) {
    const uint64_t x = rng.next();
    for (int b = 0; b < 8; ++b)
      d.bytes[static_cast<size_t>(8 * w + b)] = static_cast<uint8_t>(x >> (8 * b));
  }
  return d;
}

// `d` with exactly `flips` distinct bits inverted.
inline Descriptor flipBits(Descriptor d, int flips, SplitMix64& rng) {
  std::vector<bool> done(kDescriptorBits, false);
  for (int f = 0; f < flips;) {
    const int bit = static_cast<int>(rng.below(kDescriptorBits));
    if (done[static_cast<size_t>(bit)]) continue;
    done[static_cast<size_t>(bit)] = true;
    d.bytes[static_cast<size_t>(bit >> 3)] ^= static_cast<uint8_t>(1u << (bit & 7));
    ++f;
  }
  return d;
}

}  // namespace evermap::bow::testing
