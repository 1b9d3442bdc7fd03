#pragma once
// Time in the mapper. Message time (utime, microseconds) drives every decision; the wall clock
// and the thread's CPU clock only measure what work costs (MapperTiming, LcmNode's publishing
// and store times), never an input.

#include <chrono>
#include <cmath>
#include <cstdint>
#include <ctime>

namespace evermap::mapper {

using Clock = std::chrono::steady_clock;

inline double secondsSince(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// CPU time of the calling thread: a step's work without the time other threads and processes
// held the core (measurement only, like the wall clock above).
inline double threadCpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

// Seconds of message time as utime microseconds.
inline int64_t micros(double s) { return static_cast<int64_t>(std::llround(s * 1e6)); }

}  // namespace evermap::mapper
