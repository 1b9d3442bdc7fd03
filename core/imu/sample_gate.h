#pragma once
// The first stage every IMU sample passes through, in imu-proc and elevator-proc alike: real
// sensors deliver NaN, saturated readings, repeated or out-of-order time stamps and gaps.
// A sample that cannot be used is dropped and counted here, never passed on.

#include <cstdint>
#include <string>

#include "core/common/expected.h"
#include "core/common/option_fields.h"
#include "core/imu/imu_sample.h"

namespace evermap::imu {

struct SampleGateOptions {
  // A reading whose magnitude on any axis reaches this fraction of full scale is taken as
  // saturated (the sensor clipped; the true value is unknown).
  double accel_full_scale_m_s2 = 16.0 * 9.80665;  // a common +-16 g range
  double gyro_full_scale_rad_s = 34.9;            // +-2000 deg/s
  double saturation_fraction = 0.999;
  // Two samples closer than this are the same instant (a repeated time stamp).
  double min_interval_s = 50e-6;  // 20 kHz, far above any IMU we read
  // A larger interval is a gap: the sample is used, but the caller is told to not integrate
  // across it.
  double max_interval_s = 0.5;

  Status validate() const;
  // Keys prefixed "gate_" by the structs that hold a gate.
  void declareOptions(OptionList& o) {
    o.add("accel_full_scale_m_s2", &accel_full_scale_m_s2, "m/s^2", "accelerometer full scale")
        .positive();
    o.add("gyro_full_scale_rad_s", &gyro_full_scale_rad_s, "rad/s", "gyroscope full scale")
        .positive();
    o.add("saturation_fraction", &saturation_fraction, "",
          "an axis beyond this fraction of full scale is saturated")
        .above(0)
        .max(1);
    o.add("min_interval_s", &min_interval_s, "s", "samples closer than this are the same instant")
        .nonNegative();
    o.add("max_interval_s", &max_interval_s, "s", "a longer interval is a gap (above the minimum)")
        .positive();
  }
};

// Counts of what the gate let through and what it dropped, by reason.
struct SampleGateCounts {
  int64_t accepted = 0;
  int64_t non_finite = 0;     // NaN or inf in any field
  int64_t saturated = 0;      // an axis at full scale
  int64_t repeated_time = 0;  // time stamp equal to (or within min_interval_s of) the last
  int64_t out_of_order = 0;   // time stamp before the last accepted one
  int64_t gaps = 0;           // accepted samples that follow a gap > max_interval_s

  int64_t dropped() const { return non_finite + saturated + repeated_time + out_of_order; }
  std::string summary() const;
};

enum class GateVerdict {
  kAccept,          // use it; dt_s is the interval since the previous accepted sample
  kAcceptAfterGap,  // use it, but do not integrate across the gap (or this is the first)
  kDrop,            // unusable; counted
};

class SampleGate {
 public:
  explicit SampleGate(const SampleGateOptions& options = {});

  // Classifies one sample; on kAccept, *dt_s is the time since the previous accepted sample.
  GateVerdict check(const ImuSample& s, double* dt_s);
  const SampleGateCounts& counts() const { return counts_; }
  // Forget the last time stamp (e.g. a log was restarted); counts are kept.
  void resetTime() { have_last_ = false; }

 private:
  SampleGateOptions options_;
  SampleGateCounts counts_;
  bool have_last_ = false;
  int64_t last_utime_ = 0;
};

}  // namespace evermap::imu
