#include "tools/lcmlog/mutate.h"

#include <algorithm>
#include <iterator>

namespace evermap::messages {

std::vector<uint8_t> mutateLcm(const std::vector<uint8_t>& original, std::mt19937_64& rng) {
  static constexpr uint32_t kLengths[] = {0u,          1u,          0x10000u,   1u << 28,
                                          0x7fffffffu, 0x80000000u, 0xffffffffu};
  std::vector<uint8_t> b = original;
  const auto pick = [&rng](size_t n) { return static_cast<size_t>(rng() % n); };
  switch (pick(8)) {
    case 0:
    case 1:
      if (b.size() > 8) {
        for (size_t k = 0, n = 1 + pick(4); k < n; ++k)
          b[8 + pick(b.size() - 8)] = static_cast<uint8_t>(rng());
      }
      break;
    case 2:
    case 3:
      if (b.size() >= 12) {
        const size_t at = 8 + pick(b.size() - 11);
        const uint32_t v = kLengths[pick(std::size(kLengths))];
        for (int k = 0; k < 4; ++k) b[at + k] = static_cast<uint8_t>(v >> (24 - 8 * k));
      }
      break;
    case 4:
      b.resize(pick(b.size() + 1));
      break;
    case 5:
    case 6:
      for (size_t k = 0, n = 1 + pick(64); k < n; ++k) b.push_back(static_cast<uint8_t>(rng()));
      break;
    default: {
      const size_t keep = std::min<size_t>(8, b.size());
      b.resize(keep + pick(600));
      for (size_t k = keep; k < b.size(); ++k) b[k] = static_cast<uint8_t>(rng());
    }
  }
  return b;
}

}  // namespace evermap::messages
