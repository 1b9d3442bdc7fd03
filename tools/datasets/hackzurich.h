#pragma once
// Reader for the "elevator-imu-baro-hackzurich" phone recordings (HackZurich 2016, "Motion
// analytics in the wild"): sessionN_accelerometer.csv, _gyrometer.csv, _barometer.csv and
// the episode labels (sessionN*_episode_*.json).
//
// The phone is an iPhone (Core Motion): accelerometer rows are in g with the iOS sign
// (-1 on z lying face up), i.e. the NEGATIVE specific force; they are returned as specific
// force in m/s^2 (+g up at rest). Gyro rows are rad/s in the same device frame. The two
// sensors have their own time stamps; each accelerometer row gets the gyro reading
// interpolated at its time, and rows with no gyro reading near them are left out (counted,
// and printed by evermap-imu-elevator-run). A session without a gyrometer file is read as
// accelerometer-only: every row, with a zero gyro.

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "core/common/expected.h"
#include "tools/datasets/euroc.h"

namespace evermap::datasets {

struct BarometerSample {
  int64_t t_ns = 0;
  double pressure_kpa = 0;
  double altitude_m = 0;  // the phone's relative altitude from pressure
};

struct LabelledEpisode {
  int64_t start_ns = 0;
  int64_t end_ns = 0;
  std::string label;
  std::string description;
};

struct HackzurichSession {
  std::vector<imu::ImuSample> imu;  // one per accelerometer row with a gyro reading near it
  std::vector<BarometerSample> barometer;
  std::vector<LabelledEpisode> episodes;
  int64_t accelerometer_rows = 0;
  int64_t rows_without_gyro = 0;
  bool has_gyroscope = true;  // false: no gyrometer file, imu[].gyro_rad_s are 0
};

// Reads session `session` (1, 2, ...) from dir. max_gyro_offset_s: how far from an
// accelerometer row a gyro reading may be for interpolation (or nearest-neighbour use).
Expected<HackzurichSession> readHackzurichSession(const std::filesystem::path& dir, int session,
                                                  double max_gyro_offset_s = 0.15);

// The episode labels: a JSON array of {"start_time", "end_time" (unix seconds, number or
// string), "label", "description"}.
Expected<std::vector<LabelledEpisode>> readHackzurichEpisodes(const std::filesystem::path& json);

}  // namespace evermap::datasets
