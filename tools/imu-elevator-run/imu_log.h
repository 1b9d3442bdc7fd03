#pragma once
// IMU samples from an LCM log file (lcm-logger's format), for the offline runner and tests.

#include <string>
#include <vector>

#include "core/common/expected.h"
#include "core/imu/sample_gate.h"

namespace evermap::imu {

struct ImuLog {
  std::vector<ImuSample> samples;  // in log order (time problems are the gate's to judge)
  int64_t undecodable = 0;         // events on the channel that were not an imu_t
};

Expected<ImuLog> readImuLog(const std::string& file, const std::string& channel);

// Writes samples as imu_t events on channel (event time = sample time); to a temporary
// name in the same folder, then renamed.
Status writeImuLog(const std::string& file, const std::string& channel,
                   const std::vector<ImuSample>& samples);

}  // namespace evermap::imu
