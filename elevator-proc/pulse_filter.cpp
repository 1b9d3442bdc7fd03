#include "elevator-proc/pulse_filter.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "core/common/contract.h"

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
  if (plateau_fractions.empty()) return makeError("pulse plateau_fractions must not be empty");
  for (double f : plateau_fractions) {
    if (!(f >= 0 && f < 1)) return makeError("pulse plateau_fractions must be in [0, 1)");
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
  requireValid(options_.validate(), "evermap::elevator::PulseFilter");
  flank_ = static_cast<int>(std::lround(options_.flank_s / options_.bin_s));
  for (double w : options_.widths_s) {
    const int n = static_cast<int>(std::lround(w / options_.bin_s));
    widths_.push_back(n);
    for (double p : options_.plateau_fractions) {
      if (p > 0 && w < options_.plateau_min_width_s - 1e-9) continue;
      Template t;
      t.width = n;
      t.plateau_fraction = p;
      t.h = shape(n, p);
      for (double x : t.h) {
        t.sum += x;
        t.energy += x * x;
      }
      templates_.push_back(std::move(t));
    }
  }
}

std::vector<double> PulseFilter::shape(int n, double plateau_fraction) {
  // Tukey window: half-cosine ramps over (1 - p) n / 2 bins at each end, flat in between.
  std::vector<double> h(n);
  const double ramp = 0.5 * (1.0 - plateau_fraction) * n;
  for (int i = 0; i < n; ++i) {
    const double x = i + 0.5;
    const double edge = std::min(x, n - x);  // distance from the nearer end, bins
    h[i] = edge >= ramp ? 1.0 : 0.5 - 0.5 * std::cos(std::numbers::pi * edge / ramp);
  }
  return h;
}

std::vector<Pulse> PulseFilter::flush() {
  std::vector<Pulse> out = finalize(std::numeric_limits<int64_t>::max());
  reset();
  return out;
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
  return finalize(index - longestWidthBins());
}

namespace {
// Overlapping by more than a quarter of the shorter window: the same event. (Less is
// allowed: a ride with no cruise has its two pulses back to back.)
bool sameEvent(const Pulse& p, const Pulse& q) {
  const int64_t common =
      std::min(p.lastBin(), q.lastBin()) - std::max(p.firstBin(), q.firstBin()) + 1;
  return common > std::min(p.width_bins, q.width_bins) / 4;
}
}  // namespace

std::vector<Pulse> PulseFilter::finalize(int64_t horizon) {
  std::vector<Pulse> out;
  bool any = false;
  for (const Pulse& p : pending_) any = any || p.lastBin() < horizon;
  if (!any) return out;
  // Non-maximum suppression over every candidate known, in order of snr (greedy, as in
  // object detection): a candidate is kept when no kept one of higher snr is the same event.
  // Suppressing on arrival instead loses a pulse whose suppressor is itself suppressed later.
  std::vector<const Pulse*> order;
  for (const Pulse& p : pending_) order.push_back(&p);
  std::stable_sort(order.begin(), order.end(),
                   [](const Pulse* a, const Pulse* b) { return a->snr > b->snr; });
  std::vector<const Pulse*> kept;
  for (const Pulse* p : order) {
    bool suppressed = false;
    for (const Pulse* k : kept) suppressed = suppressed || sameEvent(*p, *k);
    if (!suppressed) kept.push_back(p);
  }
  for (const Pulse* k : kept) {
    if (k->lastBin() < horizon) out.push_back(*k);
  }
  // What remains pending: candidates still open that are not the same event as a final one.
  std::vector<Pulse> keep_pending;
  for (const Pulse& p : pending_) {
    if (p.lastBin() < horizon) continue;
    bool taken = false;
    for (const Pulse& f : out) taken = taken || sameEvent(p, f);
    if (!taken) keep_pending.push_back(p);
  }
  pending_ = std::move(keep_pending);
  std::sort(out.begin(), out.end(),
            [](const Pulse& a, const Pulse& b) { return a.center_bin < b.center_bin; });
  return out;
}

void PulseFilter::evaluate(int64_t end_index) {
  const int available = static_cast<int>(values_.size());
  for (const Template& t : templates_) {
    const int n = t.width;
    const int total = n + flank_;
    if (available < total) break;
    const std::vector<double>& h = t.h;
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
    const double hsum = t.sum;
    Pulse p;
    p.plateau_fraction = t.plateau_fraction;
    p.shape_sum = t.sum;
    p.shape_energy = t.energy;
    p.width_bins = n;
    p.center_bin = end_index - n + 1 + n / 2;
    p.amplitude_m_s2 = A;
    p.baseline_m_s2 = c + offset_;
    p.residual_m_s2 = e;
    p.snr = snr;
    p.strict = strict;
    p.delta_v_m_s = A * hsum * options_.bin_s;
    pending_.push_back(p);
  }
}

}  // namespace evermap::elevator
