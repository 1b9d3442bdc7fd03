#include "imu-proc/attitude_stream.h"

#include "imu-proc/lcm_convert.h"

namespace evermap::imu {

std::optional<attitude_t> AttitudeStream::add(const imu_t& msg) {
  if (!filter_.add(fromLcm(msg)) || !filter_.initialized()) return std::nullopt;
  const Attitude att = filter_.attitude();
  // Decimate; the 1 ms slack lets a 10.0 Hz input through at 10 Hz despite jitter.
  if (published_any_ && att.utime - last_published_ < period_us_ - 1000) return std::nullopt;
  published_any_ = true;
  last_published_ = att.utime;
  return toLcm(att);
}

}  // namespace evermap::imu
