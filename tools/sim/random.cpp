#include "tools/sim/random.h"

#include <cmath>
#include <numbers>

namespace evermap::sim {

uint64_t mixSeed(uint64_t seed, uint64_t stream) {
  uint64_t z = seed + 0x9E3779B97F4A7C15ull * (stream + 1);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

int64_t Random::index(int64_t n) {
  const unsigned __int128 product =
      static_cast<unsigned __int128>(engine_()) * static_cast<unsigned __int128>(n);
  return static_cast<int64_t>(product >> 64);
}

double Random::normal() {
  const double u1 = 1.0 - uniform();  // (0, 1]: log stays finite
  const double u2 = uniform();
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * std::numbers::pi * u2);
}

double Random::exponential(double mean) { return -mean * std::log(1.0 - uniform()); }

}  // namespace evermap::sim
