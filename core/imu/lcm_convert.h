#pragma once
// Between LCM messages and the library's value types. imu_t <-> ImuSample is the one
// conversion of an IMU message (the data-set converters write with toLcm, the processes and
// the offline runners read with fromLcm). It copies the fields and refuses nothing: the
// checks of a sample (finite, not saturated, in time order) are the SampleGate's, which every
// consumer passes it through, so a NaN sample is dropped and counted there
// (SampleGateCounts::non_finite, in imu-proc's and elevator-proc's summaries).

#include <evermap/attitude_t.hpp>
#include <evermap/imu_t.hpp>

#include "core/imu/attitude.h"
#include "core/imu/imu_sample.h"

namespace evermap::imu {

inline ImuSample fromLcm(const imu_t& m) {
  ImuSample s;
  s.utime = m.utime;
  s.gyro_rad_s = {m.angular_velocity[0], m.angular_velocity[1], m.angular_velocity[2]};
  s.accel_m_s2 = {m.linear_acceleration[0], m.linear_acceleration[1], m.linear_acceleration[2]};
  return s;
}

inline imu_t toLcm(const ImuSample& s) {
  imu_t m;
  m.utime = s.utime;
  for (int i = 0; i < 3; ++i) {
    m.angular_velocity[i] = s.gyro_rad_s[i];
    m.linear_acceleration[i] = s.accel_m_s2[i];
  }
  return m;
}

inline attitude_t toLcm(const Attitude& a) {
  attitude_t m{};
  m.utime = a.utime;
  m.roll_rad = a.roll_rad;
  m.pitch_rad = a.pitch_rad;
  for (int r = 0; r < 2; ++r)
    for (int c = 0; c < 2; ++c) m.covariance[2 * r + c] = a.covariance(r, c);
  m.accel_trusted = a.accel_trusted ? 1 : 0;
  return m;
}

inline Attitude fromLcm(const attitude_t& m) {
  Attitude a;
  a.utime = m.utime;
  a.roll_rad = m.roll_rad;
  a.pitch_rad = m.pitch_rad;
  a.covariance << m.covariance[0], m.covariance[1], m.covariance[2], m.covariance[3];
  a.accel_trusted = m.accel_trusted != 0;
  return a;
}

}  // namespace evermap::imu
