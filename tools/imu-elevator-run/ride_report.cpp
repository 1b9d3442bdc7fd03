#include "tools/imu-elevator-run/ride_report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace evermap::elevator {

namespace {
bool medianAltitude(const std::vector<datasets::BarometerSample>& baro, int64_t from_ns,
                    int64_t to_ns, double* out) {
  std::vector<double> v;
  for (const auto& b : baro) {
    if (b.t_ns >= from_ns && b.t_ns <= to_ns && std::isfinite(b.altitude_m))
      v.push_back(b.altitude_m);
  }
  if (v.empty()) return false;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  *out = v[v.size() / 2];
  return true;
}
}  // namespace

bool baroChange(const std::vector<datasets::BarometerSample>& baro, int64_t start_utime,
                int64_t end_utime, double* change_m) {
  const int64_t s = start_utime * 1000, e = end_utime * 1000, sec = 1'000'000'000;
  double before = 0, after = 0;
  if (!medianAltitude(baro, s - 6 * sec, s, &before)) return false;
  if (!medianAltitude(baro, e + 3 * sec, e + 9 * sec, &after)) return false;
  *change_m = after - before;
  return true;
}

bool baroPeakRate(const std::vector<datasets::BarometerSample>& baro, int64_t from_utime,
                  int64_t to_utime, double* rate_m_s) {
  const int64_t from = from_utime * 1000, to = to_utime * 1000, sec = 1'000'000'000;
  // The samples in the window, in time order (the file's order is not relied on).
  std::vector<datasets::BarometerSample> w;
  for (const auto& b : baro) {
    if (b.t_ns >= from && b.t_ns <= to && std::isfinite(b.altitude_m)) w.push_back(b);
  }
  std::sort(w.begin(), w.end(), [](const auto& x, const auto& y) { return x.t_ns < y.t_ns; });
  bool any = false;
  double best = 0;
  for (auto a = w.begin(); a != w.end(); ++a) {
    for (auto b = a + 1; b != w.end() && b->t_ns - a->t_ns <= 6 * sec; ++b) {
      if (b->t_ns - a->t_ns < 2 * sec) continue;
      best = std::max(best, std::abs(b->altitude_m - a->altitude_m) /
                                (1e-9 * static_cast<double>(b->t_ns - a->t_ns)));
      any = true;
    }
  }
  *rate_m_s = best;
  return any;
}

std::vector<RideRow> ridesWithReference(const std::vector<Ride>& rides,
                                        const std::vector<datasets::BarometerSample>& baro,
                                        const std::vector<datasets::LabelledEpisode>& episodes) {
  std::vector<RideRow> rows;
  for (const Ride& r : rides) {
    RideRow row;
    row.ride = r;
    row.has_baro = baroChange(baro, r.start_utime, r.end_utime, &row.baro_change_m) &&
                   baroPeakRate(baro, r.start_utime - 5'000'000, r.end_utime + 15'000'000,
                                &row.baro_peak_rate_m_s);
    for (const auto& e : episodes) {
      if (r.start_utime * 1000 < e.end_ns && r.end_utime * 1000 > e.start_ns) row.episode = e.label;
    }
    rows.push_back(row);
  }
  return rows;
}

std::string formatRideTable(const std::vector<RideRow>& rows, int64_t origin) {
  std::string out =
      "  #   start_s     end_s  dur_s  disp_m  sigma_m  baro_m  diff_m  baro_v  floor  episode\n";
  char buf[256];
  int i = 0;
  for (const auto& row : rows) {
    const auto& r = row.ride;
    char baro[32] = "     -", diff[32] = "     -", rate[32] = "     -";
    if (row.has_baro) {
      std::snprintf(baro, sizeof baro, "%6.2f", row.baro_change_m);
      std::snprintf(diff, sizeof diff, "%6.2f", r.displacement_m - row.baro_change_m);
      std::snprintf(rate, sizeof rate, "%6.2f", row.baro_peak_rate_m_s);
    }
    std::snprintf(buf, sizeof buf,
                  "%3d %9.1f %9.1f %6.1f %7.2f %8.2f  %s  %s  %s  %2d->%-2d%s %s\n", ++i,
                  1e-6 * static_cast<double>(r.start_utime - origin),
                  1e-6 * static_cast<double>(r.end_utime - origin),
                  1e-6 * static_cast<double>(r.end_utime - r.start_utime), r.displacement_m,
                  r.sigma_m, baro, diff, rate, r.from_floor, r.to_floor, r.new_floor ? "*" : " ",
                  row.episode == "-" ? "- (outside the episodes)" : row.episode.c_str());
    out += buf;
  }
  return out;
}

}  // namespace evermap::elevator
