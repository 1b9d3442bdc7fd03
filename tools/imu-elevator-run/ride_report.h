#pragma once
// The per-ride table of evermap-imu-elevator-run: each ride next to the barometric altitude
// change over it and the labelled episode it falls in.

#include <string>
#include <vector>

#include "elevator-proc/elevator_tracker.h"
#include "tools/datasets/hackzurich.h"

namespace evermap::elevator {

struct RideRow {
  Ride ride;
  bool has_baro = false;
  double baro_change_m = 0;
  // Fastest barometric climb or descent around the ride (baroPeakRate over [start - 5 s,
  // end + 15 s]): an elevator moves at ~1-1.5 m/s, a person on stairs at < 0.5 m/s.
  double baro_peak_rate_m_s = 0;
  std::string episode = "-";  // label of the episode holding the ride, "-" when none
};

// Barometric altitude change over a ride: the median altitude over [end + 3 s, end + 9 s]
// minus that over [start - 6 s, start] (the phone's pressure altitude lags by 2-4 s).
bool baroChange(const std::vector<datasets::BarometerSample>& baro, int64_t start_utime,
                int64_t end_utime, double* change_m);

// Largest |altitude change| / time between two barometer samples 2 to 6 s apart, both in
// [from, to]; false when no such pair exists (the phone's altitude is noisy sample to sample,
// so shorter spans are not used).
bool baroPeakRate(const std::vector<datasets::BarometerSample>& baro, int64_t from_utime,
                  int64_t to_utime, double* rate_m_s);

std::vector<RideRow> ridesWithReference(const std::vector<Ride>& rides,
                                        const std::vector<datasets::BarometerSample>& baro,
                                        const std::vector<datasets::LabelledEpisode>& episodes);

// Fixed-width text table, one ride a line.
std::string formatRideTable(const std::vector<RideRow>& rows, int64_t time_origin_utime);

}  // namespace evermap::elevator
