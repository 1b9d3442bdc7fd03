#pragma once
// What the two simulators share about time and randomness: one numbered random stream per
// purpose and session (so switching a sensor on or off never changes another's noise), and
// the fixed-rate clock of every sensor.

#include <cmath>
#include <cstdint>

#include "tools/sim/random.h"

namespace evermap::sim {

// Stream numbers: one per purpose, plus the session index. Both simulators draw a purpose
// from the same stream, so the image level's wheel or IMU noise equals the measurement level's.
enum class Stream : uint64_t {
  kVoNoise = 2000,
  kWheelNoise = 3000,
  kAttitudeNoise = 4000,
  kImuNoise = 5000,
  kFloorNoise = 6000,
  kPassersBy = 7000,
  kSlips = 8000,
  kRenderNoise = 10000,
  kTextures = 10100,
  kPainting = 10200,
  kPasserbyLook = 10400,
  kDepthNoise = 10500,
  kGyroBias = 11000,
  kGyroHeading = 12000,
};

inline Random streamFor(uint64_t seed, Stream s, int session) {
  return Random::derive(seed, static_cast<uint64_t>(s) + static_cast<uint64_t>(session));
}

// Ticks start + round(k * period) for k = first_k, first_k + 1, ..., in µs.
class TickClock {
 public:
  TickClock(int64_t start, double rate_hz, int64_t first_k = 0)
      : start_(start), period_us_(1e6 / rate_hz), k_(first_k) {}
  int64_t next() const { return start_ + std::llround(static_cast<double>(k_) * period_us_); }
  void advance() { ++k_; }
  // Moves to the first tick at or after t.
  void skipTo(int64_t t) {
    const auto k = static_cast<int64_t>(std::ceil(static_cast<double>(t - start_) / period_us_));
    if (k > k_) k_ = k;
    while (next() < t) ++k_;
  }

 private:
  int64_t start_;
  double period_us_;
  int64_t k_;
};

}  // namespace evermap::sim
