#include "elevator-proc/pulse_filter.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <numbers>

namespace evermap::elevator {

Status PulseFilterOptions::validate() const {
  if (!(bin_s > 0 && bin_s <= 0.5)) return makeError("pulse bin_s must be in (0, 0.5]");
  if (widths_s.empty()) return makeError("pulse widths_s must not be empty");
  for (size_t i = 0; i < widths_s.size(); ++i) {
    if (!(widths_s[i] >= 3 * bin_s)) return makeError("pulse widths_s must be >= 3 bins");
    if (i > 0 && !(widths_s[i] > widths_s[i - 1])) {
      return makeError("pulse widths_s must increase");
    }
  }
  if (!(min_amplitude_m_s2 > 0 && max_amplitude_m_s2 > min_amplitude_m_s2)) {
    return makeError("pulse amplitudes: need 0 < min < max");
  }
  if (!(max_residual_m_s2 > 0) || !(max_residual_ratio > 0)) {
    return makeError("pulse max_residual_m_s2 and max_residual_ratio must be > 0");
  }
  if (!(max_residual_loose_m_s2 >= max_residual_m_s2) ||
      !(max_residual_ratio_loose >= max_residual_ratio)) {
    return makeError("pulse loose residual limits must be >= the strict ones");
  }
  if (!(noise_floor_m_s2 > 0) || !(min_snr > 0) || !(min_snr_loose > 0)) {
    return makeError("pulse noise_floor_m_s2 and min_snr must be > 0");
  }
  if (!(flank_s >= 0)) return makeError("pulse flank_s must be >= 0");
  if (!(max_missing_fraction >= 0 && max_missing_fraction < 1)) {
    return makeError("pulse max_missing_fraction must be in [0, 1)");
  }
  return Ok{};
}

PulseFilter::PulseFilter(const PulseFilterOptions& options) : options_(options) {
  if (const Status st = options_.validate(); !st.ok()) {
    std::fprintf(stderr, "evermap::elevator::PulseFilter: %s\n", st.error().message.c_str());
    std::abort();
  }
  flank_ = static_cast<int>(std::lround(options_.flank_s / options_.bin_s));
  for (double w : options_.widths_s) {
    const int n = static_cast<int>(std::lround(w / options_.bin_s));
    widths_.push_back(n);
    std::vector<double> h(n);
    for (int i = 0; i < n; ++i) {
      h[i] = 0.5 - 0.5 * std::cos(2.0 * std::numbers::pi * (i + 0.5) / n);
    }
    hann_.push_back(std::move(h));
  }
}

void PulseFilter::reset() {
  values_.clear();
  valid_.clear();
  pending_.clear();
  last_index_ = -1;
}

std::vector<Pulse> PulseFilter::add(int64_t index, double accel_m_s2, bool valid) {
  if (last_index_ >= 0 && index != last_index_ + 1) reset();
  last_index_ = index;
  values_.push_back(valid ? accel_m_s2 : 0.0);
  valid_.push_back(valid);
  const size_t keep = static_cast<size_t>(longestWidthBins());
  while (values_.size() > keep) {
    values_.pop_front();
    valid_.pop_front();
  }
  evaluate(index);

  // A candidate is final once no window that could overlap it is still to come: every
  // later window starts after index - longest + 1.
  std::vector<Pulse> out;
  const int64_t horizon = index - longestWidthBins();
  std::vector<Pulse> keep_pending;
  for (const Pulse& p : pending_) {
    if (p.lastBin() >= horizon) {
      keep_pending.push_back(p);
      continue;
    }
    out.push_back(p);
  }
  pending_ = std::move(keep_pending);
  std::sort(out.begin(), out.end(),
            [](const Pulse& a, const Pulse& b) { return a.center_bin < b.center_bin; });
  return out;
}

void PulseFilter::evaluate(int64_t end_index) {
  const int available = static_cast<int>(values_.size());
  for (size_t w = 0; w < widths_.size(); ++w) {
    const int n = widths_[w];
    const int total = n + flank_;
    if (available < total) break;
    const std::vector<double>& h = hann_[w];
    const int offset = available - total;
    // Sums over the valid cells of the padded window (h = 0 on the flanks).
    int m = 0;
    double s1 = 0, sh = 0, shh = 0, sa = 0, sah = 0, saa = 0;
    for (int i = 0; i < total; ++i) {
      if (!valid_[offset + i]) continue;
      const double hi = (i >= flank_ && i < flank_ + n) ? h[i - flank_] : 0.0;
      const double ai = values_[offset + i] - offset_;
      ++m;
      s1 += 1;
      sh += hi;
      shh += hi * hi;
      sa += ai;
      sah += ai * hi;
      saa += ai * ai;
    }
    if (total - m > options_.max_missing_fraction * total || m < 3) continue;
    // Without a flank the baseline is not observable apart from a wide pulse: it is the
    // caller's zero (its gravity reference), and the fit has the amplitude alone.
    const bool fit_baseline = flank_ > 0;
    const double det = fit_baseline ? s1 * shh - sh * sh : s1 * shh;
    if (det <= 1e-12) continue;
    const double A = fit_baseline ? (s1 * sah - sa * sh) / det : sah / shh;
    const double c = fit_baseline ? (sa - A * sh) / s1 : 0.0;
    if (std::abs(A) < options_.min_amplitude_m_s2 || std::abs(A) > options_.max_amplitude_m_s2) {
      continue;
    }
    // Residual sum of squares of the two-parameter fit, from the sums.
    const double rss = std::max(0.0, saa - c * sa - A * sah);
    const double e = std::sqrt(rss / m);
    if (e > options_.max_residual_loose_m_s2 ||
        e > options_.max_residual_ratio_loose * std::abs(A)) {
      continue;
    }
    const bool strict =
        e <= options_.max_residual_m_s2 && e <= options_.max_residual_ratio * std::abs(A);
    const double snr = std::abs(A) * std::sqrt(det / s1) / std::max(e, options_.noise_floor_m_s2);
    if (snr < (strict ? options_.min_snr : options_.min_snr_loose)) continue;
    double hsum = 0;
    for (double x : h) hsum += x;
    Pulse p;
    p.width_bins = n;
    p.center_bin = end_index - n + 1 + n / 2;
    p.amplitude_m_s2 = A;
    p.baseline_m_s2 = c + offset_;
    p.residual_m_s2 = e;
    p.snr = snr;
    p.strict = strict;
    p.delta_v_m_s = A * hsum * options_.bin_s;
    // Non-maximum suppression against the pending candidates it overlaps.
    bool dominated = false;
    std::vector<Pulse> survivors;
    for (const Pulse& q : pending_) {
      // Overlapping by more than a quarter of the shorter window: the same event. (Less is
      // allowed: a ride with no cruise has its two pulses back to back.)
      const int64_t common = std::min(p.lastBin(), q.lastBin()) -
                             std::max(p.firstBin(), q.firstBin()) + 1;
      const bool overlap = common > std::min(p.width_bins, q.width_bins) / 4;
      if (!overlap) {
        survivors.push_back(q);
      } else if (q.snr >= p.snr) {
        dominated = true;
        survivors.push_back(q);
      }
    }
    if (!dominated) survivors.push_back(p);
    pending_ = std::move(survivors);
  }
}

}  // namespace evermap::elevator
