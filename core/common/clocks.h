#pragma once
// Time. Message time (utime, microseconds) drives every decision; the wall clock and the
// thread's CPU clock only measure what work costs (step and component times, benchmarks),
// never an input: same log, same result.

#include <chrono>
#include <cmath>
#include <cstdint>
#include <ctime>

namespace evermap {

using SteadyClock = std::chrono::steady_clock;

inline double secondsSince(SteadyClock::time_point t0) {
  return std::chrono::duration<double>(SteadyClock::now() - t0).count();
}

// CPU time of the calling thread, seconds: a piece of work without the time other threads
// and processes held the core (on a shared machine the wall clock counts that wait too).
inline double threadCpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

// Seconds of message time as utime microseconds.
inline int64_t micros(double s) { return static_cast<int64_t>(std::llround(s * 1e6)); }

}  // namespace evermap
