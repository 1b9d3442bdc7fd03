#include "elevator-proc/elevator_tracker.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "core/common/contract.h"

namespace evermap::elevator {

namespace {
const ElevatorTrackerOptions& checked(const ElevatorTrackerOptions& o) {
  requireValid(o.validate(), "evermap::elevator::ElevatorTracker");
  return o;
}
}  // namespace

ElevatorTracker::ElevatorTracker(const ElevatorTrackerOptions& options)
    : options_(checked(options)),
      gate_(options.gate),
      pulse_filter_(options.pulse),
      // The latency of a confirmed start after the cells that raise the alarm: the longest
      // template, the low band's and the step window's delays, the lead-in after the pulse.
      watch_(options.watch, options.pulse.bin_s,
             options.pulse.widths_s.back() + options.lowpass_width_s + options.step_window_s +
                 options.lead_in_s),
      floors_(options.floors),
      bin_us_(static_cast<int64_t>(std::llround(options.pulse.bin_s * 1e6))),
      gravity_(options.initial_gravity_m_s2) {
  // The low band's Hann: zero at +-half bins, so half - 1 cells on each side weigh in.
  const int half =
      static_cast<int>(std::lround(options_.lowpass_width_s / (2 * options_.pulse.bin_s)));
  lowpass_half_ = std::max(0, half - 1);
  for (int j = 0; j <= lowpass_half_; ++j) {
    lowpass_.push_back(half > 1 ? 0.5 + 0.5 * std::cos(std::numbers::pi * j / half) : 1.0);
  }
  step_half_ = static_cast<int>(std::lround(options_.step_window_s / (2 * options_.pulse.bin_s)));
}

int64_t ElevatorTracker::binUtime(int64_t index) const { return index * bin_us_ + bin_us_ / 2; }

const ElevatorTracker::Bin* ElevatorTracker::bin(int64_t index) const {
  if (index < history_first_ || index >= history_first_ + static_cast<int64_t>(history_.size())) {
    return nullptr;
  }
  return &history_[static_cast<size_t>(index - history_first_)];
}

std::vector<FloorEvent> ElevatorTracker::add(const imu::ImuSample& sample,
                                             const imu::Attitude* attitude) {
  std::vector<FloorEvent> events;
  double dt = 0;
  if (gate_.check(sample, &dt) == imu::GateVerdict::kDrop) return events;
  if (!attitude || std::abs(attitude->utime - sample.utime) >
                       static_cast<int64_t>(options_.max_attitude_age_s * 1e6)) {
    ++counts_.no_attitude;
    return events;
  }
  const int64_t index = sample.utime / bin_us_;
  if (open_index_ >= 0 && index != open_index_) {
    closeBin(&events);
    const int64_t missing = index - open_index_ - 1;
    const int64_t max_fill = static_cast<int64_t>(options_.max_fill_s / options_.pulse.bin_s);
    const int64_t max_missing =
        static_cast<int64_t>(options_.max_gap_in_ride_s / options_.pulse.bin_s);
    if (missing <= max_fill) {
      // Filled when the next cell closes, by interpolation (a 10 Hz phone with jittered
      // time stamps leaves every fourth cell of the grid empty).
      fill_pending_ = missing;
    } else if (missing <= max_missing) {
      for (int64_t k = open_index_ + 1; k < index; ++k) processBin(k, Bin{}, &events);
    } else {
      // A long gap: nothing across it can be integrated. Pulses pending before it are final
      // (a stop just before the gap still ends its ride); then start the grid again.
      drain(&events);
      for (const Pulse& p : pulse_filter_.flush()) onPulse(p, &events);
      if (!starts_.empty()) abandon(open_index_, "gap in the data", &events);
      pulse_filter_.reset();
      history_.clear();
      have_last_closed_ = false;
    }
  }
  if (open_index_ != index) {
    open_index_ = index;
    open_sum_ = 0;
    open_count_ = 0;
  }
  // Vertical specific force: f projected on "up" in the body frame.
  const Eigen::Vector3d up = imu::upFromRollPitch(attitude->roll_rad, attitude->pitch_rad);
  open_sum_ += up.dot(sample.accel_m_s2);
  ++open_count_;
  ++counts_.samples_used;
  return events;
}

std::vector<FloorEvent> ElevatorTracker::finish() {
  std::vector<FloorEvent> events;
  if (open_index_ >= 0) {
    closeBin(&events);
    open_index_ = -1;
  }
  drain(&events);
  for (const Pulse& p : pulse_filter_.flush()) onPulse(p, &events);
  const int64_t last =
      history_.empty() ? 0 : history_first_ + static_cast<int64_t>(history_.size()) - 1;
  if (!starts_.empty()) abandon(last, "end of the data before a stop", &events);
  announce(watch_.finish(), last, &events);
  history_.clear();
  have_last_closed_ = false;
  return events;
}

bool ElevatorTracker::gravityPlausible() const {
  return std::abs(gravity_ - options_.gravity_nominal_m_s2) <= options_.max_gravity_error_m_s2;
}

void ElevatorTracker::closeBin(std::vector<FloorEvent>* events) {
  Bin b;
  if (open_count_ > 0) {
    const double raw = open_sum_ / open_count_;
    if (!gravity_seeded_) {
      gravity_ = raw;
      gravity_seeded_ = true;
    }
    b.raw = raw;
    b.gravity = gravity_;
    b.accel = raw - gravity_;
    b.valid = true;
    if (fill_pending_ > 0 && have_last_closed_) {
      for (int64_t j = 1; j <= fill_pending_; ++j) {
        Bin f = b;
        f.raw = last_closed_raw_ + (raw - last_closed_raw_) * static_cast<double>(j) /
                                       static_cast<double>(fill_pending_ + 1);
        f.accel = f.raw - gravity_;
        ++counts_.filled_bins;
        processBin(open_index_ - fill_pending_ - 1 + j, f, events);
      }
    } else {
      for (int64_t j = 1; j <= fill_pending_; ++j) {
        processBin(open_index_ - fill_pending_ - 1 + j, Bin{}, events);
      }
    }
    fill_pending_ = 0;
    last_closed_raw_ = raw;
    have_last_closed_ = true;
  }
  processBin(open_index_, b, events);
}

void ElevatorTracker::processBin(int64_t index, const Bin& in, std::vector<FloorEvent>* events) {
  Bin b = in;
  if (history_.empty()) history_first_ = index;
  // Motion: standard deviation of a over the last motion_window_s (valid bins).
  const int window = static_cast<int>(std::lround(options_.motion_window_s / options_.pulse.bin_s));
  double sum = b.valid ? b.accel : 0, sum2 = b.valid ? b.accel * b.accel : 0;
  int n = b.valid ? 1 : 0;
  for (int k = 1; k < window; ++k) {
    const Bin* p = bin(index - k);
    if (p && p->valid) {
      sum += p->accel;
      sum2 += p->accel * p->accel;
      ++n;
    }
  }
  b.motion = n >= 2 ? std::sqrt(std::max(0.0, sum2 / n - (sum / n) * (sum / n))) : 0.0;
  history_.push_back(b);
  ++counts_.bins;
  if (!b.valid) ++counts_.empty_bins;
  const size_t keep = static_cast<size_t>(
      (options_.max_ride_s + options_.lead_in_s + 4 * options_.pulse.widths_s.back() + 2.0) /
          options_.pulse.bin_s +
      lowpass_half_ + step_half_);
  while (history_.size() > keep) {
    history_.pop_front();
    ++history_first_;
  }
  // The reference is frozen during rides and while a pulse may be under way: a start pulse
  // seen by the median (after a walk into the cabin there are few calm cells) would
  // otherwise become the new zero, and the cruise after it a false stop pulse.
  pending_bins_ = pulse_filter_.pending() ? pending_bins_ + 1 : 0;
  const bool frozen =
      pending_bins_ > 0 && pending_bins_ * options_.pulse.bin_s <= options_.max_gravity_freeze_s;
  // Until a reference from calm cells exists there is nothing worth freezing (the first
  // cell's value, taken while a phone is put down, can be 2 m/s^2 off).
  if (starts_.empty() && (!frozen || !calm_reference_)) updateGravity(index);
  splitBands(index - lowpass_half_, events);
  announce(watch_.add(index, b.accel, b.valid, b.motion, walking_, !starts_.empty()), index,
           events);
}

void ElevatorTracker::announce(VerticalWatch::Change change, int64_t index,
                               std::vector<FloorEvent>* events) {
  if (change == VerticalWatch::Change::kNone) return;
  FloorEvent e;
  e.utime = binUtime(index);
  e.kind = change == VerticalWatch::Change::kMotion ? FloorEvent::Kind::kVerticalMotion
                                                    : FloorEvent::Kind::kVerticalStill;
  e.floor_index = floors_.current();
  e.height_m = floors_.currentHeight();
  events->push_back(e);
  if (change == VerticalWatch::Change::kMotion) ++counts_.vertical_alarms;
}

void ElevatorTracker::splitBands(int64_t index, std::vector<FloorEvent>* events) {
  Bin* c = mutableBin(index);
  if (!c) return;
  if (c->valid) {
    double sum = 0, weight = 0;
    for (int j = -lowpass_half_; j <= lowpass_half_; ++j) {
      const Bin* b = bin(index + j);
      if (!b || !b->valid) continue;
      sum += lowpass_[static_cast<size_t>(std::abs(j))] * b->raw;
      weight += lowpass_[static_cast<size_t>(std::abs(j))];
    }
    c->low = sum / weight;
  }
  updateWalking(index - step_half_);
  fed_index_ = index;
  for (const Pulse& p : pulse_filter_.add(index, c->accel, c->valid)) onPulse(p, events);
  if (!starts_.empty()) checkRide(index, events);
}

void ElevatorTracker::drain(std::vector<FloorEvent>* events) {
  if (history_.empty()) return;
  const int64_t last = history_first_ + static_cast<int64_t>(history_.size()) - 1;
  for (int64_t k = std::max(fed_index_ + 1, history_first_); k <= last; ++k) {
    splitBands(k, events);
  }
  for (int64_t k = std::max(last - step_half_ + 1, history_first_); k <= last; ++k) {
    updateWalking(k);
  }
}

void ElevatorTracker::updateWalking(int64_t index) {
  Bin* c = mutableBin(index);
  if (!c) return;
  // Step energy: rms of the signal above the low band (its low is known up to fed_index_ + 1).
  double sum2 = 0;
  int n = 0;
  for (int j = -step_half_; j <= step_half_; ++j) {
    const Bin* b = bin(index + j);
    if (!b || !b->valid || index + j > fed_index_ + 1) continue;
    sum2 += (b->raw - b->low) * (b->raw - b->low);
    ++n;
  }
  c->step = n > 0 ? std::sqrt(sum2 / n) : 0.0;
  if (c->valid) {
    walking_ = walking_ ? c->step > options_.walking_step_off_m_s2
                        : c->step > options_.walking_step_on_m_s2;
  }
  c->walking = walking_;
  if (trace_) {
    trace_->push_back({binUtime(index), c->accel, c->motion, c->step, c->walking, c->gravity,
                       c->valid, !starts_.empty()});
  }
}

void ElevatorTracker::checkRide(int64_t index, std::vector<FloorEvent>* events) {
  // Checks on a cell old enough that every pulse ending before it is final: people walk out
  // right after the stop pulse, and that must not end the ride it completes.
  const int64_t checked = index - pulse_filter_.longestWidthBins() - 1;
  if (checked > starts_.back().lastBin()) {
    const Bin* c = bin(checked);
    walking_bins_ = (c && c->valid && c->walking) ? walking_bins_ + 1 : 0;
    // Not while a pulse may still be under way: riders step toward the door during the stop.
    if (walking_bins_ * options_.pulse.bin_s > options_.max_walking_in_ride_s &&
        !pulse_filter_.pending()) {
      abandon(index, "walking", events);
      return;
    }
  }
  // Start candidates older than the longest ride expire.
  const int64_t max_bins = static_cast<int64_t>(options_.max_ride_s / options_.pulse.bin_s);
  if (index - starts_.back().firstBin() > max_bins) {
    abandon(index, "no stop pulse within max_ride_s", events);
    return;
  }
  std::erase_if(starts_, [&](const Pulse& p) { return index - p.firstBin() > max_bins; });
}

void ElevatorTracker::updateGravity(int64_t index) {
  const int window = static_cast<int>(options_.gravity_window_s / options_.pulse.bin_s);
  scratch_.clear();
  for (int k = 0; k < window; ++k) {
    const Bin* b = bin(index - k);
    if (!b) break;
    if (b->valid && b->motion < options_.calm_std_m_s2) scratch_.push_back(b->raw);
  }
  const double calm_s = static_cast<double>(scratch_.size()) * options_.pulse.bin_s;
  if (calm_s + 1e-9 >= options_.gravity_min_calm_s) {
    gravity_established_ = true;
  } else if (gravity_established_ || calm_s + 1e-9 < options_.gravity_provisional_calm_s) {
    // Too little calm: keep the reference (an established one, or the first cell's).
    return;
  }
  std::nth_element(scratch_.begin(), scratch_.begin() + scratch_.size() / 2, scratch_.end());
  gravity_ = scratch_[scratch_.size() / 2];
  calm_reference_ = true;
}

void ElevatorTracker::onPulse(const Pulse& q, std::vector<FloorEvent>* events) {
  ++counts_.pulses;
  if (pulse_trace_) pulse_trace_->push_back(q);
  if (!starts_.empty() && tryFinish(q, events)) return;
  // The stop pulse of a finished ride is no start.
  if (q.firstBin() <= last_ride_end_bin_ || !startable(q)) return;
  if (starts_.empty()) {
    walking_bins_ = 0;
    FloorEvent e;
    e.utime = binUtime(q.firstBin());
    e.kind = FloorEvent::Kind::kRideStart;
    e.floor_index = -1;
    e.height_m = floors_.currentHeight();
    e.in_elevator = true;
    events->push_back(e);
  }
  starts_.push_back(q);
}

bool ElevatorTracker::tryFinish(const Pulse& q, std::vector<FloorEvent>* events) {
  // The open start of opposite sign that this stop completes best (velocity changes
  // alike once the ride's level is removed, small bias).
  const Pulse* best = nullptr;
  RideFit best_fit;
  double best_score = 0;
  for (const Pulse& p : starts_) {
    if ((p.amplitude_m_s2 > 0) == (q.amplitude_m_s2 > 0)) continue;
    if (q.firstBin() <= p.lastBin() - p.width_bins / 4) continue;
    RideFit fit;
    if (!fitRide(p, q, &fit)) continue;
    // The bias the zero-velocity constraint found is the error of the zero level; it added
    // bias sum(h) / sum(h^2) to each amplitude (4/3 bias for a Hann), bias sum(h)^2 /
    // sum(h^2) dt to each velocity change (2/3 width dt for a Hann).
    const double dt = options_.pulse.bin_s;
    const double dv_start =
        p.delta_v_m_s - fit.bias * p.shape_sum * p.shape_sum / p.shape_energy * dt;
    const double dv_stop =
        q.delta_v_m_s - fit.bias * q.shape_sum * q.shape_sum / q.shape_energy * dt;
    if ((dv_start > 0) == (dv_stop > 0)) continue;
    const double ratio = std::abs(dv_stop) / std::max(std::abs(dv_start), 1e-6);
    if (q.strict) {
      if (ratio < 1.0 / options_.max_pulse_ratio || ratio > options_.max_pulse_ratio) continue;
    } else if (std::abs(fit.raw_end_velocity) > options_.max_loose_closure * std::abs(dv_start)) {
      // A stop mixed with the rider's own motion (turning to the door) has a poorly
      // measured velocity change of its own; instead, the velocity integrated over the
      // whole ride must come back near zero.
      continue;
    }
    const double score = std::abs(std::log(ratio)) + std::abs(fit.bias) / options_.max_bias_m_s2;
    if (!best || score < best_score) {
      best = &p;
      best_fit = fit;
      best_score = score;
    }
  }
  if (!best) return false;
  const Pulse start = *best;
  if (const std::string why = sanity(best_fit); !why.empty()) {
    RejectedRide r;
    r.start_utime = binUtime(start.firstBin()) - bin_us_ / 2;
    r.end_utime = binUtime(q.lastBin()) + bin_us_ / 2;
    r.displacement_m = best_fit.displacement;
    r.peak_speed_m_s = best_fit.peak_speed;
    r.reason = why;
    rejected_.push_back(r);
    ++counts_.rejected;
    starts_.clear();
    // Still on the floor left, as for an abandoned start: a listener does not wait.
    FloorEvent e;
    e.utime = r.end_utime;
    e.kind = FloorEvent::Kind::kRideEnd;
    e.floor_index = floors_.current();
    e.height_m = floors_.currentHeight();
    events->push_back(e);
    last_ride_end_bin_ = q.lastBin();
    return true;
  }
  finishRide(start, q, best_fit, events);
  last_ride_end_bin_ = q.lastBin();
  return true;
}

bool ElevatorTracker::startable(const Pulse& p) const {
  if (!p.strict || std::abs(p.delta_v_m_s) < options_.min_ride_speed_m_s) return false;
  // A cab starts while its riders stand: no step in the middle half of the pulse (stairs and
  // escalators change the vertical speed while stepping).
  for (int64_t k = p.firstBin() + p.width_bins / 4; k <= p.lastBin() - p.width_bins / 4; ++k) {
    const Bin* b = bin(k);
    if (!b || b->walking) return false;
  }
  const int lead = static_cast<int>(std::lround(options_.lead_in_s / options_.pulse.bin_s));
  int n_pre = 0;
  double pre = 0;
  for (int k = 1; k <= lead; ++k) {
    const Bin* b = bin(p.firstBin() - k);
    if (!b) return false;  // not enough history to know the level before it
    if (b->valid) {
      pre += b->low - b->gravity;
      ++n_pre;
    }
  }
  // Measured from the level before it rather than from the gravity reference (which may be
  // stale after the phone turned): a constant c adds sum(h)/sum(h^2) c to the fit (4/3 c
  // for a Hann).
  if (n_pre > 0) {
    const double relative = p.amplitude_m_s2 - p.shape_sum / p.shape_energy * pre / n_pre;
    if (relative * p.amplitude_m_s2 <= 0 ||
        std::abs(relative) < options_.pulse.min_amplitude_m_s2) {
      return false;
    }
  }
  // A pulse returns to the level it left (the cruise is unaccelerated); a step does not (the
  // phone turned to another face, where the accelerometer reads another g). The stop of a
  // ride with no cruise comes right after and goes the other way, which this allows.
  int n_post = 0;
  double post = 0;
  for (int k = 1; k <= lead; ++k) {
    const Bin* b = bin(p.lastBin() + k);
    if (b && b->valid) {
      post += b->low - b->gravity;
      ++n_post;
    }
  }
  if (n_pre > 0 && n_post > 0) {
    const double step = (post / n_post - pre / n_pre) * (p.amplitude_m_s2 > 0 ? 1.0 : -1.0);
    if (step > options_.max_step_fraction * std::abs(p.amplitude_m_s2)) return false;
  }
  return true;
}

bool ElevatorTracker::fitRide(const Pulse& start, const Pulse& stop, RideFit* fit) const {
  const int64_t first = start.firstBin();
  const int64_t last = stop.lastBin();
  const int n = static_cast<int>(last - first + 1);
  std::vector<double> a(n, 0.0);
  std::vector<double> motion;
  const Bin* first_bin = bin(first);
  if (!first_bin) return false;
  const double reference = first_bin->gravity + start.baseline_m_s2;
  // Missing cells are bridged linearly between their valid neighbours.
  int prev_valid = -1;
  for (int i = 0; i < n; ++i) {
    const Bin* b = bin(first + i);
    if (!b) return false;
    if (!b->valid) continue;
    // One reference for the whole ride (the gravity reference may have moved within it;
    // a constant is what the zero-velocity constraint removes).
    a[i] = b->raw - reference;
    motion.push_back(b->motion);
    if (prev_valid >= 0 && i - prev_valid > 1) {
      for (int j = prev_valid + 1; j < i; ++j) {
        const double f = static_cast<double>(j - prev_valid) / (i - prev_valid);
        a[j] = (1 - f) * a[prev_valid] + f * a[i];
      }
    }
    prev_valid = i;
  }
  if (motion.empty()) return false;
  const double dt = options_.pulse.bin_s;
  // Zero velocity at both ends: the constant bias b with sum(a - b) dt = 0.
  double bias = 0;
  for (double x : a) bias += x / n;
  fit->raw_end_velocity = bias * n * options_.pulse.bin_s;
  double v = 0, d = 0, peak = 0;
  const double sign = start.amplitude_m_s2 > 0 ? 1.0 : -1.0;
  std::vector<double> velocity(n);
  for (int i = 0; i < n; ++i) {
    v += (a[i] - bias) * dt;
    d += v * dt;
    peak = std::max(peak, std::abs(v));
    velocity[i] = v;
  }
  // The cruise: after the start pulse, before the stop pulse.
  const int cruise_first = static_cast<int>(start.lastBin() + 1 - first);
  const int cruise_last = static_cast<int>(stop.firstBin() - 1 - first);
  fit->cruise_spread = 0;
  if (cruise_last >= cruise_first) {
    double mean = 0;
    for (int i = cruise_first; i <= cruise_last; ++i) mean += velocity[i];
    mean /= cruise_last - cruise_first + 1;
    for (int i = cruise_first; i <= cruise_last; ++i) {
      fit->cruise_spread = std::max(fit->cruise_spread, std::abs(velocity[i] - mean));
    }
  }
  fit->reverse = 0;
  for (double x : velocity) fit->reverse = std::max(fit->reverse, -sign * x);
  fit->duration = n * dt;
  const bool direction_ok = (d > 0) == (start.amplitude_m_s2 > 0);
  if (std::abs(bias) > options_.max_bias_m_s2 || peak < options_.min_ride_speed_m_s ||
      std::abs(d) < options_.min_displacement_m || !direction_ok) {
    return false;
  }
  // Height variance: white acceleration noise through a velocity Brownian bridge,
  // Var(integral of the bridge over T) = q T^3 / 12, plus a relative scale error.
  std::nth_element(motion.begin(), motion.begin() + motion.size() / 2, motion.end());
  const double sigma_a = motion[motion.size() / 2];
  const double T = n * dt;
  fit->displacement = d;
  fit->bias = bias;
  fit->peak_speed = peak;
  fit->sigma = std::sqrt(sigma_a * sigma_a * dt * T * T * T / 12.0 +
                         std::pow(options_.scale_sigma_fraction * d, 2));
  return true;
}

std::string ElevatorTracker::sanity(const RideFit& fit) const {
  char buf[200];
  if (!gravityPlausible()) {
    std::snprintf(
        buf, sizeof buf,
        "the accelerometer does not measure gravity (reference %.2f m/s^2, expected %.2f): "
        "a gravity-removed stream? elevator-proc needs the specific force",
        gravity_, options_.gravity_nominal_m_s2);
    return buf;
  }
  const double spread_limit = options_.max_cruise_velocity_spread_m_s +
                              options_.max_cruise_velocity_spread_fraction * fit.peak_speed;
  if (fit.cruise_spread > spread_limit) {
    std::snprintf(buf, sizeof buf,
                  "velocity not steady between the pulses (%.2f m/s off its mean, limit %.2f)",
                  fit.cruise_spread, spread_limit);
    return buf;
  }
  if (fit.reverse > options_.max_reverse_velocity_fraction * fit.peak_speed) {
    std::snprintf(buf, sizeof buf, "velocity reverses (%.2f m/s against the ride, peak %.2f)",
                  fit.reverse, fit.peak_speed);
    return buf;
  }
  const double fill = std::abs(fit.displacement) / std::max(fit.peak_speed * fit.duration, 1e-9);
  if (fill < options_.min_profile_fill) {
    std::snprintf(buf, sizeof buf,
                  "displacement %.2f m inconsistent with the velocity profile (%.2f of peak %.2f "
                  "m/s x %.1f s)",
                  fit.displacement, fill, fit.peak_speed, fit.duration);
    return buf;
  }
  const FloorAssignment to = floors_.peek(fit.displacement);
  if (!to.is_new && to.index == floors_.current()) {
    std::snprintf(buf, sizeof buf,
                  "displacement %.2f m reaches no other floor (the floor left is nearest)",
                  fit.displacement);
    return buf;
  }
  return {};
}

void ElevatorTracker::finishRide(const Pulse& start, const Pulse& stop, const RideFit& fit,
                                 std::vector<FloorEvent>* events) {
  Ride r;
  r.start_utime = binUtime(start.firstBin()) - bin_us_ / 2;
  r.end_utime = binUtime(stop.lastBin()) + bin_us_ / 2;
  r.displacement_m = fit.displacement;
  r.sigma_m = fit.sigma;
  r.peak_speed_m_s = fit.peak_speed;
  r.start_accel_m_s2 = start.amplitude_m_s2;
  r.stop_accel_m_s2 = stop.amplitude_m_s2;
  r.bias_m_s2 = fit.bias;
  r.from_floor = floors_.current();
  const FloorAssignment to = floors_.arrive(fit.displacement);
  r.to_floor = to.index;
  r.new_floor = to.is_new;
  rides_.push_back(r);
  ++counts_.rides;
  starts_.clear();  // every open start lies before this stop
  FloorEvent e;
  e.utime = r.end_utime;
  e.kind = FloorEvent::Kind::kRideEnd;
  e.floor_index = to.index;
  e.height_m = to.height_m;
  e.height_sigma_m = r.sigma_m;
  e.in_elevator = false;
  e.new_floor = to.is_new;
  events->push_back(e);
}

void ElevatorTracker::abandon(int64_t now_index, const std::string& reason,
                              std::vector<FloorEvent>* events) {
  const int64_t first = starts_.empty() ? now_index : starts_.front().firstBin();
  abandoned_.push_back({binUtime(first), binUtime(now_index), reason});
  ++counts_.abandoned;
  starts_.clear();
  // Still on the floor we left: say so, so a listener does not wait for an end.
  FloorEvent e;
  e.utime = binUtime(now_index);
  e.kind = FloorEvent::Kind::kRideEnd;
  e.floor_index = floors_.current();
  e.height_m = floors_.currentHeight();
  e.in_elevator = false;
  events->push_back(e);
}

}  // namespace evermap::elevator
