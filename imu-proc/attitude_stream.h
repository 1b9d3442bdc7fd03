#pragma once
// imu-proc's output stream: the AttitudeFilter fed with every IMU sample, its attitude
// decimated to publish_rate_hz (ATTITUDE), with the gyro's heading (HeadingIntegrator). One class
// for the process and the offline runner of the whole system, so both publish the same messages.

#include <cstdint>
#include <optional>

#include <evermap/attitude_t.hpp>
#include <evermap/imu_t.hpp>

#include "imu-proc/attitude_filter.h"
#include "imu-proc/heading_integrator.h"

namespace evermap::imu {

class AttitudeStream {
 public:
  // Contract: options valid (AttitudeFilter aborts otherwise), publish_rate_hz > 0.
  AttitudeStream(const AttitudeFilterOptions& options, double publish_rate_hz,
                 const HeadingOptions& heading = {})
      : filter_(options),
        heading_(heading),
        period_us_(static_cast<int64_t>(1e6 / publish_rate_hz)) {}

  // One IMU sample; the ATTITUDE message due after it, if any.
  std::optional<attitude_t> add(const imu_t& msg);

  const AttitudeFilter& filter() const { return filter_; }
  const HeadingIntegrator& heading() const { return heading_; }

 private:
  AttitudeFilter filter_;
  HeadingIntegrator heading_;
  int64_t period_us_;
  int64_t last_published_ = 0;
  bool published_any_ = false;
};

}  // namespace evermap::imu
