#include "imu-proc/attitude_stream.h"

#include "core/imu/lcm_convert.h"

namespace evermap::imu {

std::optional<attitude_t> AttitudeStream::add(const imu_t& msg) {
  const ImuSample sample = fromLcm(msg);
  if (!filter_.add(sample) || !filter_.initialized()) return std::nullopt;
  const Attitude att = filter_.attitude();
  heading_.add(sample, core::SO3d::fromRollPitchYaw(att.roll_rad, att.pitch_rad, 0.0));
  // Decimate; the 1 ms slack lets a 10.0 Hz input through at 10 Hz despite jitter.
  if (published_any_ && att.utime - last_published_ < period_us_ - 1000) return std::nullopt;
  published_any_ = true;
  last_published_ = att.utime;
  attitude_t out = toLcm(att);
  out.heading_rad = heading_.headingRad();
  out.heading_rate_sigma_rad_s = heading_.rateSigmaRadS();
  out.heading_valid = heading_.started() ? 1 : 0;
  out.heading_epoch = heading_.epoch();
  return out;
}

}  // namespace evermap::imu
