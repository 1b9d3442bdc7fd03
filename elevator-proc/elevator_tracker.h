#pragma once
// Elevator rides and floors from the accelerometer (paper section IV-F, DESIGN.md section 6).
//
//   IMU sample + attitude -> vertical acceleration a = up(roll, pitch) . f - g_local
//   -> averaged on a 0.1 s grid (any input rate from 10 Hz to 1 kHz)
//   -> matched filter (PulseFilter) -> start pulse ... opposite stop pulse
//   -> displacement: a integrated twice between them with the velocity zero at both ends
//      (the constant accelerometer bias b that makes v(end) = 0 is removed first:
//       b = mean(a) over the ride, v(t) = sum(a - b) dt, d = sum(v) dt)
//   -> FloorTable: nearest floor within a threshold, else a new floor.
// The start is confirmed only once the filter's longest template has passed it (10+ s); the
// VerticalWatch (vertical_watch.h) announces vertical motion at once (EVENT_VERTICAL_MOTION),
// and stillness when no ride followed (EVENT_VERTICAL_STILL).
//
// Walking is told from standing by band: the energy of the signal above a 1.4 s low-pass
// (steps are 1.5-2.5 Hz, a ride's pulse under 0.7 Hz), with hysteresis. A ride starts only
// from a strict start pulse during which the rider stands (no walking over its middle half;
// the walk into the cab may end just before it), measured from the level before it (not a
// step of the accelerometer's g when a phone turns);
// it ends with a pulse of the opposite sign carrying a similar velocity change (or, for a
// stop mixed with the rider's own motion, one that brings the integrated velocity back near
// zero); it is abandoned on sustained walking once no pulse is pending, a long gap, or when it runs
// too long. Several start candidates may be open at once; a stop completes the one it fits best.
// Stairs, walking and sitting down leave pulse residuals far above the limits; an escalator's
// vertical speed changes while stepping on, and stays below min_ride_speed besides.
//
// Time comes only from the samples' time stamps. Not thread-safe; one instance per stream.

#include <cstdint>
#include <deque>
#include <string>
#include <vector>

#include "core/common/expected.h"
#include "core/common/option_fields.h"
#include "core/imu/attitude.h"
#include "core/imu/sample_gate.h"
#include "elevator-proc/floor_table.h"
#include "elevator-proc/pulse_filter.h"
#include "elevator-proc/vertical_watch.h"

namespace evermap::elevator {

struct ElevatorTrackerOptions {
  PulseFilterOptions pulse;
  FloorTableOptions floors;
  VerticalWatchOptions watch;
  imu::SampleGateOptions gate;
  // Gravity reference (the accelerometer's own g, which also moves by a few 0.1 m/s^2 when
  // a phone changes face: per-axis bias): the median of the vertical specific force over the
  // calm cells of the last gravity_window_s outside rides; needs gravity_min_calm_s of them.
  // Start pulses are measured from their lead-in level and each ride is integrated against
  // one reference, so this only has to be roughly right.
  double gravity_window_s = 30.0;
  double gravity_min_calm_s = 8.0;
  // Until gravity_min_calm_s of calm cells have been seen (a short recording, a phone put
  // down just before the doors close), the median of at least this much calm is used; before
  // that, no ride can start anyway (a start needs a calm lead-in).
  double gravity_provisional_calm_s = 1.0;
  // A reference farther than this from gravity_nominal_m_s2 is not gravity: the input is
  // not specific force (e.g. Android's gravity-removed "linear acceleration"); every ride is
  // then rejected with that reason. (Phones read g a few % off: 10.3 is seen.)
  double gravity_nominal_m_s2 = 9.80665;
  double max_gravity_error_m_s2 = 2.0;
  // The reference is frozen while a pulse candidate is pending, at most this long.
  double max_gravity_freeze_s = 10.0;
  double initial_gravity_m_s2 = 9.80665;
  // Motion measure: standard deviation of a over this window.
  double motion_window_s = 1.0;
  // "Calm": standing still, hand-held or in a pocket (walking is 1-5 m/s^2).
  double calm_std_m_s2 = 0.35;
  // Walking vs standing, by band. A ride's acceleration pulse lies below ~0.7 Hz (phases of
  // 1.5-10 s), a person's steps at 1.5-2.5 Hz (with a stride component at half that and
  // harmonics above). The low band is a centred Hann of lowpass_width_s (zero to zero; first
  // null at 2 / width = 1.43 Hz, under 1/40 of a step left at 1.5-2.5 Hz); the step band is
  // the signal minus its low band, and its rms over a centred step_window_s, the step
  // energy, decides walking vs standing with hysteresis: walking from walking_step_on_m_s2,
  // standing again below walking_step_off_m_s2. Steps of 1-3 m/s^2 give 0.6-2 m/s^2 rms; a
  // rider standing in the cab 0.03-0.17 (HackZurich); a ride's own pulse leaks at most 0.14
  // (the sharpest of the sweep, 1.5 m/s^2 reached at 1.5 m/s^3). The matched filter and the
  // integration keep the whole signal: between a start and its stop nobody walks.
  double lowpass_width_s = 1.4;
  double step_window_s = 1.0;
  double walking_step_on_m_s2 = 0.4;
  double walking_step_off_m_s2 = 0.2;
  // The levels before and after a start pulse are measured over this much (low band).
  double lead_in_s = 1.5;
  // The level after a start pulse (over lead_in_s) may differ from the level before it by
  // at most this fraction of the pulse amplitude in the pulse's direction (else: a step).
  double max_step_fraction = 0.5;
  // Walking (the step band) for longer than this after a start pulse ends the ride attempt.
  // A start pulse is no start when the middle half of it is walking (stairs, escalators: the
  // vertical speed changes while stepping; a cab starts while its riders stand).
  double max_walking_in_ride_s = 3.0;
  // Velocity change of the start pulse, and of the ride, at least this (m/s).
  double min_ride_speed_m_s = 0.4;
  // |delta_v(stop)| / |delta_v(start)| must lie in [1/r, r] (strict stop pulses).
  double max_pulse_ratio = 2.0;
  // A loose stop pulse (see PulseFilterOptions) instead needs the velocity integrated over
  // the ride, before the zero-velocity correction, within this fraction of delta_v(start).
  double max_loose_closure = 0.6;
  // 80 floors at 4 m/s is ~80 s of cruise; 20 floors at 0.5 m/s ~140 s.
  double max_ride_s = 180.0;
  double min_displacement_m = 1.0;
  // The bias the zero-velocity constraint removes must be smaller than this.
  double max_bias_m_s2 = 0.2;
  // Sanity checks on a ride (else it is reported as rejected, with the reason):
  // - in the cruise (between the two pulses) the velocity stays within this fraction of the
  //   peak speed (plus max_cruise_velocity_spread_m_s) of its mean: a cabin does not speed up
  //   or slow down between its phases;
  double max_cruise_velocity_spread_fraction = 0.3;
  double max_cruise_velocity_spread_m_s = 0.3;
  // - the velocity never runs against the ride's direction by more than this fraction of
  //   the peak speed;
  double max_reverse_velocity_fraction = 0.2;
  // - |displacement| >= this fraction of peak speed x duration (a profile of two pulses with
  //   no cruise gives 1/2);
  double min_profile_fill = 0.35;
  // - the ride arrives on another floor of the table (more than floor_match_threshold_m, half
  //   a storey, away from the floor left).
  // Relative scale uncertainty of the displacement (accelerometer scale, g error), for
  // height_sigma_m, added to the random-walk term.
  double scale_sigma_fraction = 0.05;
  // Grid cells without samples: runs up to max_fill_s are filled by interpolation; longer
  // ones are left empty (the matched filter tolerates a few); a gap longer than
  // max_gap_in_ride_s abandons a ride and restarts the grid.
  double max_fill_s = 0.5;
  double max_gap_in_ride_s = 1.0;
  // Attitude older (or newer) than this relative to the IMU sample is not used.
  double max_attitude_age_s = 0.5;

  Status validate() const;
  // Every setting once: key, unit, range, doc (core/common/option_fields.h).
  void declareOptions(OptionList& o) {
    declarePulseOptions(o);
    declareGravityOptions(o);
    declareRideOptions(o);
    o.nest("gate_", &gate);
    o.nest("watch_", &watch);
  }
  void declarePulseOptions(OptionList& o) {
    o.add("pulse_bin_s", &pulse.bin_s, "s", "grid the vertical acceleration is averaged onto")
        .above(0)
        .max(0.5);
    o.add("pulse_plateau_min_width_s", &pulse.plateau_min_width_s, "s",
          "plateau templates only from this width on")
        .any();
    o.add("pulse_min_amplitude_m_s2", &pulse.min_amplitude_m_s2, "m/s^2",
          "a smaller pulse is not an elevator")
        .positive();
    o.add("pulse_max_amplitude_m_s2", &pulse.max_amplitude_m_s2, "m/s^2",
          "a larger pulse is not a cabin (above the minimum)")
        .positive();
    o.add("pulse_max_residual_m_s2", &pulse.max_residual_m_s2, "m/s^2",
          "rms misfit of the pulse shape at most")
        .positive();
    o.add("pulse_max_residual_ratio", &pulse.max_residual_ratio, "",
          "... and relative to the amplitude")
        .positive();
    o.add("pulse_max_residual_loose_m_s2", &pulse.max_residual_loose_m_s2, "m/s^2",
          "misfit of an expected (stop) pulse at most")
        .positive();
    o.add("pulse_max_residual_ratio_loose", &pulse.max_residual_ratio_loose, "",
          "... and relative to the amplitude")
        .positive();
    o.add("pulse_min_snr_loose", &pulse.min_snr_loose, "",
          "signal-to-noise of an expected pulse at least")
        .positive();
    o.add("pulse_noise_floor_m_s2", &pulse.noise_floor_m_s2, "m/s^2", "noise assumed at least this")
        .positive();
    o.add("pulse_min_snr", &pulse.min_snr, "", "signal-to-noise of a pulse at least").positive();
    o.add("pulse_flank_s", &pulse.flank_s, "s",
          "flank of zeros before the template; 0: no baseline fit")
        .nonNegative();
    o.add("pulse_max_missing_fraction", &pulse.max_missing_fraction, "",
          "windows missing more bins are not evaluated")
        .min(0)
        .below(1);
    o.add("floor_match_threshold_m", &floors.match_threshold_m, "m",
          "a ride ends on a known floor within this")
        .positive();
    o.add("floor_refine_weight", &floors.refine_weight, "",
          "weight of a new arrival in a floor's height")
        .in(0, 1);
  }
  void declareGravityOptions(OptionList& o) {
    o.add("gravity_window_s", &gravity_window_s, "s",
          "gravity is the median of the calm cells over this")
        .positive();
    o.add("gravity_min_calm_s", &gravity_min_calm_s, "s",
          "... of at least this much calm (at most the window)")
        .positive();
    o.add("gravity_provisional_calm_s", &gravity_provisional_calm_s, "s",
          "until then, of at least this much")
        .positive();
    o.add("gravity_nominal_m_s2", &gravity_nominal_m_s2, "m/s^2", "the gravity expected")
        .positive();
    o.add("max_gravity_error_m_s2", &max_gravity_error_m_s2, "m/s^2",
          "a reference farther from nominal is not gravity")
        .positive();
    o.add("max_gravity_freeze_s", &max_gravity_freeze_s, "s",
          "reference frozen while a pulse is pending, at most")
        .nonNegative();
    o.add("initial_gravity_m_s2", &initial_gravity_m_s2, "m/s^2", "reference before any calm")
        .positive();
    o.add("motion_window_s", &motion_window_s, "s",
          "motion is the std of the acceleration over this")
        .positive();
    o.add("calm_std_m_s2", &calm_std_m_s2, "m/s^2", "motion below this is calm").positive();
    o.add("lead_in_s", &lead_in_s, "s", "levels before and after a start pulse over this")
        .positive();
    o.add("max_step_fraction", &max_step_fraction, "",
          "level change over a start pulse at most this fraction of the pulse (else a step)")
        .any();
  }
  void declareRideOptions(OptionList& o) {
    o.add("lowpass_width_s", &lowpass_width_s, "s",
          "Hann low-pass (zero to zero) that splits the steps off; null at 2/width Hz")
        .positive()
        .max(4);
    o.add("step_window_s", &step_window_s, "s", "step energy: rms of the band above, over this")
        .positive()
        .max(4);
    o.add("walking_step_on_m_s2", &walking_step_on_m_s2, "m/s^2",
          "step energy above this: walking starts")
        .positive();
    o.add("walking_step_off_m_s2", &walking_step_off_m_s2, "m/s^2",
          "step energy below this: walking ends (at most the start level)")
        .positive();
    o.add("max_walking_in_ride_s", &max_walking_in_ride_s, "s",
          "walking this long ends a ride attempt")
        .positive();
    o.add("min_ride_speed_m_s", &min_ride_speed_m_s, "m/s", "velocity change of a ride at least")
        .positive();
    o.add("max_pulse_ratio", &max_pulse_ratio, "",
          "stop and start velocity changes agree within this ratio")
        .min(1);
    o.add("max_loose_closure", &max_loose_closure, "",
          "a loose stop's integrated velocity closes within this")
        .any();
    o.add("max_ride_s", &max_ride_s, "s", "a ride lasts at most this").positive();
    o.add("min_displacement_m", &min_displacement_m, "m", "a ride moves at least this")
        .nonNegative();
    o.add("max_bias_m_s2", &max_bias_m_s2, "m/s^2",
          "the bias the zero-velocity constraint removes at most")
        .positive();
    o.add("max_cruise_velocity_spread_fraction", &max_cruise_velocity_spread_fraction, "",
          "cruise velocity within this fraction of peak speed of its mean")
        .positive();
    o.add("max_cruise_velocity_spread_m_s", &max_cruise_velocity_spread_m_s, "m/s", "... plus this")
        .nonNegative();
    o.add("max_reverse_velocity_fraction", &max_reverse_velocity_fraction, "",
          "velocity against the ride at most this fraction of peak speed")
        .nonNegative();
    o.add("min_profile_fill", &min_profile_fill, "",
          "displacement at least this fraction of peak speed x duration")
        .in(0, 1);
    o.add("scale_sigma_fraction", &scale_sigma_fraction, "",
          "relative scale uncertainty of a displacement")
        .nonNegative();
    o.add("max_fill_s", &max_fill_s, "s", "sample gaps up to this are interpolated").nonNegative();
    o.add("max_gap_in_ride_s", &max_gap_in_ride_s, "s", "a longer gap abandons a ride").positive();
    o.add("max_attitude_age_s", &max_attitude_age_s, "s",
          "attitude further than this from a sample is not used")
        .positive();
  }
};

// What elevator-proc publishes on FLOOR (evermap::floor_t).
struct FloorEvent {
  // kVerticalMotion / kVerticalStill: the watch's (vertical_watch.h), on the floor left.
  enum class Kind { kRideStart, kRideEnd, kVerticalMotion, kVerticalStill };
  int64_t utime = 0;
  Kind kind = Kind::kRideStart;
  int floor_index = -1;  // -1 while riding
  double height_m = 0;   // current floor (end) or the floor left (start)
  double height_sigma_m = 0;
  bool in_elevator = false;
  bool new_floor = false;
};

struct Ride {
  int64_t start_utime = 0;    // start of the start pulse
  int64_t end_utime = 0;      // end of the stop pulse
  double displacement_m = 0;  // up positive
  double sigma_m = 0;
  double peak_speed_m_s = 0;
  double start_accel_m_s2 = 0;  // amplitudes of the two pulses
  double stop_accel_m_s2 = 0;
  double bias_m_s2 = 0;  // removed by the zero-velocity constraint
  int from_floor = 0;
  int to_floor = 0;
  bool new_floor = false;
};

// A start and stop pair that made a ride by the pulses but failed a sanity check: never
// reported as a ride (the FLOOR end says the floor left), listed here with the reason.
struct RejectedRide {
  int64_t start_utime = 0;
  int64_t end_utime = 0;
  double displacement_m = 0;
  double peak_speed_m_s = 0;
  std::string reason;
};

struct AbandonedRide {
  int64_t start_utime = 0;
  int64_t abandon_utime = 0;
  std::string reason;
};

struct ElevatorCounts {
  int64_t samples_used = 0;
  int64_t no_attitude = 0;  // samples without an attitude close enough in time
  int64_t bins = 0;
  int64_t empty_bins = 0;   // grid cells with no sample left empty (gaps)
  int64_t filled_bins = 0;  // grid cells with no sample filled by interpolation
  int64_t pulses = 0;
  int64_t rides = 0;
  int64_t abandoned = 0;
  int64_t rejected = 0;
  int64_t vertical_alarms = 0;  // EVENT_VERTICAL_MOTION announced
  std::string summary() const;
};

// One grid cell, for plotting and debugging (see ElevatorTracker::setTrace).
struct TraceBin {
  int64_t utime = 0;
  double accel_m_s2 = 0;  // gravity removed
  double motion_std_m_s2 = 0;
  double step_rms_m_s2 = 0;  // step energy
  bool walking = false;
  double gravity_m_s2 = 0;  // the reference subtracted
  bool valid = false;
  bool riding = false;
};

class ElevatorTracker {
 public:
  // Contract: options.validate() is ok (checked; aborts otherwise).
  explicit ElevatorTracker(const ElevatorTrackerOptions& options = {});

  // One IMU sample and the attitude at (about) its time, or nullptr when none is known.
  // Returns the FLOOR events this sample completed (most samples: none).
  std::vector<FloorEvent> add(const imu::ImuSample& sample, const imu::Attitude* attitude);

  const std::vector<Ride>& rides() const { return rides_; }
  const std::vector<AbandonedRide>& abandoned() const { return abandoned_; }
  const std::vector<RejectedRide>& rejected() const { return rejected_; }
  // The end of the data: pulses still waiting to become final are decided now (a stop in
  // the last seconds completes its ride), and a ride still open is abandoned.
  std::vector<FloorEvent> finish();
  // The gravity reference now, and whether it is plausible for specific force.
  double gravityReference() const { return gravity_; }
  bool gravityPlausible() const;
  const FloorTable& floors() const { return floors_; }
  bool riding() const { return !starts_.empty(); }
  const ElevatorCounts& counts() const { return counts_; }
  const imu::SampleGateCounts& gateCounts() const { return gate_.counts(); }
  // Appends every finished grid cell to *trace and every pulse to *pulses (nullptr: off).
  void setTrace(std::vector<TraceBin>* trace, std::vector<Pulse>* pulses = nullptr) {
    trace_ = trace;
    pulse_trace_ = pulses;
  }
  int64_t binUtime(int64_t index) const;

 private:
  struct RideFit {
    double displacement = 0, bias = 0, peak_speed = 0, sigma = 0;
    double raw_end_velocity = 0;  // before the zero-velocity correction
    double cruise_spread = 0;     // max |v - mean| between the pulses
    double reverse = 0;           // largest velocity against the ride's direction
    double duration = 0;
  };
  struct Bin {
    double raw = 0;      // vertical specific force
    double gravity = 0;  // the reference when the cell was closed
    double accel = 0;    // vertical, gravity removed
    double motion = 0;
    double low = 0;   // the low band of raw (set lowpass_width_s / 2 later)
    double step = 0;  // step energy (set a further step_window_s / 2 later)
    bool walking = false;
    bool valid = false;
  };

  void closeBin(std::vector<FloorEvent>* events);
  void updateGravity(int64_t index);
  void processBin(int64_t index, const Bin& bin, std::vector<FloorEvent>* events);
  // The two bands of cell `index` (low band, then the step energy and walking state of the
  // cell step_window_s / 2 earlier) and the pulse filter fed with it; drain(): every cell
  // still waiting (the end of the data, a long gap), with the windows cut short.
  void splitBands(int64_t index, std::vector<FloorEvent>* events);
  void drain(std::vector<FloorEvent>* events);
  void updateWalking(int64_t index);
  void checkRide(int64_t index, std::vector<FloorEvent>* events);
  void onPulse(const Pulse& q, std::vector<FloorEvent>* events);
  // The sanity checks of a fitted ride: empty when it passes, else the reason.
  std::string sanity(const RideFit& fit) const;
  bool tryFinish(const Pulse& stop, std::vector<FloorEvent>* events);
  bool startable(const Pulse& p) const;
  // The zero-velocity integration from start to stop and its checks; false when it fails.
  bool fitRide(const Pulse& start, const Pulse& stop, RideFit* fit) const;
  void finishRide(const Pulse& start, const Pulse& stop, const RideFit& fit,
                  std::vector<FloorEvent>* events);
  void abandon(int64_t now_index, const std::string& reason, std::vector<FloorEvent>* events);
  // The watch's change at cell `index`, as a FLOOR event on the floor left.
  void announce(VerticalWatch::Change change, int64_t index, std::vector<FloorEvent>* events);
  const Bin* bin(int64_t index) const;
  Bin* mutableBin(int64_t index) { return const_cast<Bin*>(bin(index)); }

  ElevatorTrackerOptions options_;
  imu::SampleGate gate_;
  PulseFilter pulse_filter_;
  VerticalWatch watch_;
  FloorTable floors_;
  ElevatorCounts counts_;
  std::vector<TraceBin>* trace_ = nullptr;
  std::vector<Pulse>* pulse_trace_ = nullptr;

  // The grid: the cell being filled and the history of closed cells.
  int64_t bin_us_ = 100000;
  int64_t open_index_ = -1;
  double open_sum_ = 0;
  int open_count_ = 0;
  std::deque<Bin> history_;
  int64_t history_first_ = 0;  // grid index of history_.front()
  double gravity_ = 9.80665;
  bool gravity_seeded_ = false;
  std::vector<double> scratch_;
  int64_t pending_bins_ = 0;
  int64_t fill_pending_ = 0;  // empty cells before the open one, filled when it closes
  double last_closed_raw_ = 0;
  bool have_last_closed_ = false;

  // Open start candidates (start pulses not yet matched by a stop), in time order. A ride is
  // under way while there is one; the first pulse that completes one of them ends it.
  std::vector<Pulse> starts_;
  int64_t last_ride_end_bin_ = -1;
  int64_t walking_bins_ = 0;
  // The band split: the Hann weights (centre first), its half width and the step window's,
  // bins; the last cell fed to the pulse filter and the walking state (hysteresis).
  std::vector<double> lowpass_;
  int lowpass_half_ = 0, step_half_ = 0;
  int64_t fed_index_ = -1;
  bool walking_ = false;

  std::vector<Ride> rides_;
  std::vector<AbandonedRide> abandoned_;
  std::vector<RejectedRide> rejected_;
  bool gravity_established_ = false;  // gravity_min_calm_s of calm seen
  bool calm_reference_ = false;       // the reference is a median of calm cells
};

}  // namespace evermap::elevator
