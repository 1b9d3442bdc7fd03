#pragma once
// What the CPU running this can do, for code with an AVX2 path chosen at run time (the build
// stays plain x86-64; the AVX2 functions are compiled with __attribute__((target("avx2")))).

#include <atomic>

namespace evermap::core {

// Off: cpuHasAvx2() says false, so the portable paths run (tests compare the two).
inline std::atomic<bool>& avx2Allowed() {
  static std::atomic<bool> allowed{true};
  return allowed;
}

// True when the CPU has AVX2 (and AVX), asked once, and avx2Allowed().
inline bool cpuHasAvx2() {
  static const bool yes = [] {
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx2") != 0;
  }();
  return yes && avx2Allowed().load(std::memory_order_relaxed);
}

}  // namespace evermap::core
