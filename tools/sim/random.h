#pragma once
// Portable, repeatable random numbers for the simulators.
//
// std::mt19937_64 is fully specified by the C++ standard, but std::normal_distribution and
// friends are not (libstdc++ and libc++ draw differently), so every draw here is made from the
// raw 64-bit engine output: the same seed gives the same numbers on every standard library.
// Each purpose (building, one session's motion, one sensor's noise) gets its own stream from
// derive(), so changing one sensor's noise does not move the robot.

#include <cstdint>
#include <random>

namespace evermap::sim {

// SplitMix64 (Steele, Lea & Flood 2014): a well-mixed 64-bit seed from (seed, stream).
uint64_t mixSeed(uint64_t seed, uint64_t stream);

class Random {
 public:
  explicit Random(uint64_t seed) : engine_(seed) {}
  // An independent stream for one purpose.
  static Random derive(uint64_t seed, uint64_t stream) { return Random(mixSeed(seed, stream)); }

  uint64_t bits() { return engine_(); }
  // Uniform in [0, 1), 53 random bits.
  double uniform() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  // Uniform integer in [0, n); n > 0. Lemire's multiply-shift, without the rejection step
  // (its bias is below 2^-40 for the sizes used here).
  int64_t index(int64_t n);
  int64_t integer(int64_t lo, int64_t hi) { return lo + index(hi - lo + 1); }  // [lo, hi]
  bool bernoulli(double p) { return uniform() < p; }
  // Standard normal by Box-Muller; two uniforms per draw, no cached second value, so the
  // stream position does not depend on call parity.
  double normal();
  double normal(double mean, double sigma) { return mean + sigma * normal(); }
  // Exponential with the given mean (> 0).
  double exponential(double mean);

 private:
  std::mt19937_64 engine_;
};

}  // namespace evermap::sim
