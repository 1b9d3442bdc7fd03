#pragma once
// Reader for accelerometer recordings exported by the Android app "Science Journal"
// (../shared/data/elevator-android-skyscraper): a CSV with a header naming the columns,
//   relative_time,LinearAccelerometerSensor,AccX,AccY,AccZ
// relative_time in milliseconds from the start; AccX/AccY/AccZ the accelerometer in m/s^2
// INCLUDING gravity (specific force, device frame, +z out of the screen: +g when lying face
// up); LinearAccelerometerSensor the magnitude of Android's gravity-removed "linear
// acceleration" (a filtered sensor: not usable as specific force). Rows are sparse: each
// carries only the channels that updated, the others empty.
//
// A sample is made once all three axes have been updated since the last sample, at the time
// of the row that completes it (an axis updated twice before that keeps its newer value).
// No row is dropped without being counted: every row falls in exactly one of the counts of
// ScienceJournalRecording, and the summary prints them. There is no gyroscope: the samples'
// gyro is 0 (the attitude filter's auto mode takes that as accelerometer-only).

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "core/common/expected.h"
#include "tools/datasets/euroc.h"

namespace evermap::datasets {

struct ScienceJournalRecording {
  std::vector<imu::ImuSample> imu;       // gyro_rad_s = 0 (no gyroscope)
  int64_t rows = 0;                      // data rows (after the header)
  int64_t rows_completing_sample = 0;    // the row that completed a sample
  int64_t rows_partial = 0;              // updated some axes of a sample completed by a later row
  int64_t rows_linear_only = 0;          // only LinearAccelerometerSensor (not used, see above)
  int64_t rows_empty = 0;                // a time and nothing else
  int64_t rows_before_first_sample = 0;  // axes seen before all three were known
  int64_t values_superseded = 0;         // an axis updated again before its sample was made
  int64_t rows_trailing = 0;             // after the last sample (an incomplete triple)
  std::string summary() const;
};

// Reads a Science Journal CSV. Errors name the file and line: a missing column, a field
// that is not a number, a time going backwards.
Expected<ScienceJournalRecording> readScienceJournalCsv(const std::filesystem::path& file);

}  // namespace evermap::datasets
