#include "core/imu/sample_gate.h"

#include <cmath>
#include <cstdio>

namespace evermap::imu {

Status SampleGateOptions::validate() const {
  if (Status s = checkOptionRanges(*this, "gate_"); !s) return s;
  if (!(max_interval_s > min_interval_s)) {
    return makeError("gate_max_interval_s must be > gate_min_interval_s");
  }
  return Ok{};
}

std::string SampleGateCounts::summary() const {
  char buf[256];
  std::snprintf(buf, sizeof buf,
                "accepted %lld, dropped %lld (non-finite %lld, saturated %lld, repeated time "
                "%lld, out of order %lld), gaps %lld",
                static_cast<long long>(accepted), static_cast<long long>(dropped()),
                static_cast<long long>(non_finite), static_cast<long long>(saturated),
                static_cast<long long>(repeated_time), static_cast<long long>(out_of_order),
                static_cast<long long>(gaps));
  return buf;
}

SampleGate::SampleGate(const SampleGateOptions& options) : options_(options) {
  const Status st = options_.validate();
  if (!st.ok()) {
    std::fprintf(stderr, "evermap::imu::SampleGate: %s\n", st.error().message.c_str());
    std::abort();  // a broken contract: the caller validates options at its boundary
  }
}

GateVerdict SampleGate::check(const ImuSample& s, double* dt_s) {
  if (!s.gyro_rad_s.allFinite() || !s.accel_m_s2.allFinite()) {
    ++counts_.non_finite;
    return GateVerdict::kDrop;
  }
  const double a_lim = options_.saturation_fraction * options_.accel_full_scale_m_s2;
  const double g_lim = options_.saturation_fraction * options_.gyro_full_scale_rad_s;
  if (s.accel_m_s2.cwiseAbs().maxCoeff() >= a_lim || s.gyro_rad_s.cwiseAbs().maxCoeff() >= g_lim) {
    ++counts_.saturated;
    return GateVerdict::kDrop;
  }
  if (!have_last_) {
    have_last_ = true;
    last_utime_ = s.utime;
    ++counts_.accepted;
    *dt_s = 0.0;
    return GateVerdict::kAcceptAfterGap;
  }
  const double dt = 1e-6 * static_cast<double>(s.utime - last_utime_);
  if (dt < 0) {
    ++counts_.out_of_order;
    return GateVerdict::kDrop;
  }
  if (dt < options_.min_interval_s) {
    ++counts_.repeated_time;
    return GateVerdict::kDrop;
  }
  last_utime_ = s.utime;
  ++counts_.accepted;
  *dt_s = dt;
  if (dt > options_.max_interval_s) {
    ++counts_.gaps;
    return GateVerdict::kAcceptAfterGap;
  }
  return GateVerdict::kAccept;
}

}  // namespace evermap::imu
