#pragma once
// The matched filter of paper section IV-F: an elevator starts and stops with a smooth
// pulse of vertical acceleration (0.3-1.5 m/s^2 for 1-10 s, then cruise, then the opposite
// pulse). Lift controllers limit the jerk: a short phase is a hump, a long one (a high-rise
// lift reaching 4-10 m/s) a plateau with ramps at each end. The filter correlates the
// vertical acceleration, sampled on a fixed grid, with a bank of templates: for every width
// and every plateau fraction p, a Tukey window (a flat top over p of the width, half-cosine
// ramps over the rest; p = 0 is the Hann pulse). For each template and centre the least
// squares amplitude is
//   A = sum(a h) / sum(h^2),                                  (matched-filter output)
// the residual is e = rms(a - A h) over the window, and the detection statistic is the
// amplitude's signal-to-noise ratio  snr = |A| sqrt(sum h^2) / max(e, noise_floor)
// (the same statistic for every template, so non-maximum suppression compares like with like).
// A pulse is a window whose amplitude and residual pass the thresholds and whose snr is the
// largest among all overlapping windows of every width (non-maximum suppression). Walking,
// stairs and sitting down leave residuals of 1-5 m/s^2 and never pass; a rider standing
// in the cabin (hand or pocket) leaves 0.05-0.2.
//
// With flank_s > 0 each template is preceded by that many zeros and a baseline c is fitted
// with A (a ~ c + A h). On the phone data that cost more stops (people walk out at once,
// short rides have no cruise) than it saved, so by default the caller's zero is the
// baseline and the tracker checks a start against its lead-in level instead.

#include <cstdint>
#include <deque>
#include <vector>

#include "core/common/expected.h"

namespace evermap::elevator {

struct PulseFilterOptions {
  double bin_s = 0.1;  // the grid the vertical acceleration is averaged onto
  // Template widths (full support), s. Shortest to longest. Each width is tried with every
  // plateau fraction (0: Hann). A phase of a jerk-limited profile lasts v/a + a/j: 1-2 s for
  // a one-floor office ride, 8-10 s for a 10 m/s lift.
  std::vector<double> widths_s = {1.5, 2.5, 3.5, 5.0, 7.0, 10.0};
  std::vector<double> plateau_fractions = {0.0, 0.5, 0.8};
  // Plateau fractions > 0 are tried only from this width on: a shorter phase is fitted by
  // the Hann within the noise, and more templates there make the greedy non-maximum
  // suppression split a stop mixed with the rider's motion into pieces.
  double plateau_min_width_s = 5.0;
  double min_amplitude_m_s2 = 0.2;  // smaller is not an elevator (or is a slow escalator)
  double max_amplitude_m_s2 = 2.5;  // larger is a person or a vehicle, not a cabin
  double max_residual_m_s2 = 0.3;   // rms misfit of the pulse shape within the window
  double max_residual_ratio = 0.6;  // ... and relative to |A|
  // Looser limits for a pulse that is expected (the stop of a ride under way, often mixed
  // with the rider turning to the door); such pulses have strict = false.
  double max_residual_loose_m_s2 = 0.6;
  double max_residual_ratio_loose = 1.2;
  double min_snr_loose = 3.0;
  double noise_floor_m_s2 = 0.03;  // below the sensor's own noise, snr is not meaningful
  double min_snr = 8.0;
  // Flank of zeros before the template, s (0: no baseline fit, see above).
  double flank_s = 0.0;
  // Windows holding more missing bins than this fraction are not evaluated.
  double max_missing_fraction = 0.2;

  Status validate() const;
};

struct Pulse {
  int64_t center_bin = 0;     // index on the filter's grid
  int width_bins = 0;         // the Hann's support (without the flanks)
  double amplitude_m_s2 = 0;  // A (peak of the fitted Hann)
  double baseline_m_s2 = 0;   // c
  double residual_m_s2 = 0;
  double snr = 0;
  bool strict = true;  // passed the strict residual limits
  // Velocity change of the pulse: A * sum(h) * bin_s (= A * width / 2 for a Hann).
  double delta_v_m_s = 0;
  double plateau_fraction = 0;  // of the template (0: Hann)
  // sum(h) and sum(h^2) of the template, bins: a constant c under the pulse adds
  // c sum(h) / sum(h^2) to A and c sum(h)^2 / sum(h^2) bin_s to delta_v.
  double shape_sum = 0, shape_energy = 0;
  int64_t firstBin() const { return center_bin - width_bins / 2; }
  int64_t lastBin() const { return firstBin() + width_bins - 1; }
};

class PulseFilter {
 public:
  // Contract: options.validate() is ok.
  explicit PulseFilter(const PulseFilterOptions& options);

  // Feeds bin `index` (consecutive indices; valid = false for a bin without samples).
  // Returns the pulses that became final with this bin (each reported once, in time order,
  // about one longest template width after its end).
  std::vector<Pulse> add(int64_t index, double accel_m_s2, bool valid);
  // Forget the history (after a long gap).
  void reset();
  // The end of the data (or a long gap): every candidate pending is final now, since no
  // window that could overlap it will come. Returns them in time order, then reset().
  std::vector<Pulse> flush();
  // A level subtracted from every value when windows are evaluated (the stop filter
  // measures against the level the ride started from).
  void setOffset(double offset_m_s2) { offset_ = offset_m_s2; }
  // The longest padded window (flank + Hann), bins.
  int longestWidthBins() const { return widths_.back() + flank_; }
  // The Tukey template of n bins with a flat top over plateau_fraction of it.
  static std::vector<double> shape(int n, double plateau_fraction);
  // True while a candidate pulse waits to become final (a pulse may be under way).
  bool pending() const { return !pending_.empty(); }

 private:
  void evaluate(int64_t end_index);
  // Non-maximum suppression over the pending candidates; returns those kept that end before
  // horizon (final) and drops every candidate they suppress.
  std::vector<Pulse> finalize(int64_t horizon);

  PulseFilterOptions options_;
  std::vector<int> widths_;  // bins
  int flank_ = 0;            // bins
  double offset_ = 0;
  struct Template {
    int width = 0;  // bins
    double plateau_fraction = 0;
    std::vector<double> h;
    double sum = 0, energy = 0;
  };
  std::vector<Template> templates_;  // width-major: all shapes of widths_[0], then ...
  std::deque<double> values_;        // the last longest-width bins
  std::deque<bool> valid_;
  int64_t last_index_ = -1;
  std::vector<Pulse> pending_;  // candidates not yet final
};

}  // namespace evermap::elevator
