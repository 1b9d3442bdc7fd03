// evermap-imu-elevator-run: the offline runner of imu-proc and elevator-proc. Runs the
// attitude filter and the elevator tracker over a recording, deterministically and as fast
// as the CPU allows, and prints the attitude error (with ground truth) and the per-ride
// table (with a barometer).
//
//   evermap-imu-elevator-run --euroc-imu mav0/imu0/data.csv [--ground-truth gt.txt]
//   evermap-imu-elevator-run --hackzurich DIR --session N
//   evermap-imu-elevator-run --science-journal FILE.csv   (Android Science Journal export)
//   evermap-imu-elevator-run --lcm-log FILE [--channel IMU]
//   evermap-imu-elevator-run --synthetic N [--rate HZ]   (a building run with N rides)
//   evermap-imu-elevator-run --walking-sweep   (rides next to walking: the table of issue 50)
//   evermap-imu-elevator-run --sim-config config/sim-paper-scale.conf [--sim-set key=value]...
//          [--sim-sessions N]   (the measurement-level simulator's IMU: rides on the right floor?)
// Options: --set key=value (attitude or elevator option), --config FILE, --print-options,
//          --zero-gyro (every gyro reading set to 0: the accelerometer-only control),
//          --dump-attitude FILE, --dump-trace FILE (the elevator's 0.1 s grid),
//          --write-lcm-log FILE (the IMU samples read, as an LCM log for lcm-logplayer),
//          --print-floor-log FILE (only print the FLOOR messages of an LCM log).

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <evermap/attitude_t.hpp>
#include <evermap/floor_t.hpp>
#include <lcm/lcm-cpp.hpp>

#include "core/common/atomic_write.h"
#include "core/common/command_line.h"
#include "core/common/key_value_file.h"
#include "core/common/option_fields.h"
#include "core/messages/channels.h"
#include "core/messages/convert.h"
#include "elevator-proc/elevator_tracker.h"
#include "elevator-proc/lcm_convert.h"
#include "imu-proc/attitude_filter.h"
#include "tools/datasets/euroc.h"
#include "tools/datasets/hackzurich.h"
#include "tools/datasets/science_journal.h"
#include "tools/imu-elevator-run/attitude_evaluation.h"
#include "tools/imu-elevator-run/imu_log.h"
#include "tools/imu-elevator-run/offline_run.h"
#include "tools/imu-elevator-run/ride_report.h"
#include "tools/imu-elevator-run/ride_simulator.h"
#include "tools/imu-elevator-run/sim_floor_check.h"
#include "tools/imu-elevator-run/walking_sweep.h"
#include "tools/lcmlog/log_reader.h"

namespace {

using namespace evermap;

struct Args {
  std::string euroc_imu, ground_truth, hackzurich, science_journal, lcm_log,
      channel = channels::kImu;
  bool zero_gyro = false;
  std::string dump_attitude, dump_trace, write_lcm_log, floor_log;
  int synthetic_rides = 0;
  std::string sim_config;
  std::vector<std::string> sim_sets;
  int sim_sessions = 0;
  double rate_hz = 100.0;
  int session = 1;
  bool print_options = false;
  bool walking_sweep = false;
  imu::AttitudeFilterOptions attitude;
  elevator::ElevatorTrackerOptions elevator;
};

// The command line; -1 to run, else the exit status (usage and errors already printed).
int parse(int argc, char** argv, Args* a) {
  CommandLine cli(
      "evermap-imu-elevator-run",
      "imu-proc's attitude filter and elevator-proc's tracker over a recording, offline. One "
      "input:\n"
      "--euroc-imu, --hackzurich, --science-journal, --lcm-log, --synthetic, --sim-config or\n"
      "--walking-sweep\n"
      "(docs/imu-elevator.md).");
  cli.value("--euroc-imu", &a->euroc_imu, "CSV", "EuRoC mav0/imu0/data.csv");
  cli.value("--ground-truth", &a->ground_truth, "FILE", "EuRoC ground truth: the attitude error");
  cli.value("--hackzurich", &a->hackzurich, "DIR", "the phone recordings (with --session)");
  cli.value("--session", &a->session, "N", "HackZurich session number (default 1)").min(1);
  cli.value("--science-journal", &a->science_journal, "CSV",
            "an Android Science Journal accelerometer export (relative_time, AccX, AccY, AccZ; "
            "sparse rows)");
  cli.flag("--zero-gyro", &a->zero_gyro,
           "set every gyro reading to 0 (the accelerometer-only control)");
  cli.value("--lcm-log", &a->lcm_log, "FILE", "IMU messages of an LCM log");
  cli.value("--channel", &a->channel, "IMU", "the IMU channel of --lcm-log and --write-lcm-log");
  cli.value("--synthetic", &a->synthetic_rides, "N", "a synthetic building run with N rides")
      .min(0);
  cli.value("--rate", &a->rate_hz, "HZ", "IMU rate of --synthetic (default 100)")
      .positive()
      .max(100000);
  cli.flag("--walking-sweep", &a->walking_sweep,
           "rides next to walking at 10/50/200 Hz, gyro on/off, gaps 0.5-3 s: the table");
  cli.value("--sim-config", &a->sim_config, "FILE",
            "the measurement-level simulator's IMU: does every ride end on the right floor?");
  cli.repeated("--sim-set", &a->sim_sets, "key=value", "override one simulator setting");
  cli.value("--sim-sessions", &a->sim_sessions, "N",
            "only the first N sessions of --sim-config (0: all)")
      .min(0);
  cli.flag("--print-options", &a->print_options, "the same as --print-config");
  cli.options(&a->attitude);
  cli.options(&a->elevator);
  cli.check([a] { return a->attitude.validate(); });
  cli.check([a] { return a->elevator.validate(); });
  cli.value("--dump-attitude", &a->dump_attitude, "FILE",
            "the attitude track, one estimate a line");
  cli.value("--dump-trace", &a->dump_trace, "FILE", "the elevator's 0.1 s grid");
  cli.value("--write-lcm-log", &a->write_lcm_log, "FILE",
            "the IMU samples read, as an LCM log for lcm-logplayer");
  cli.value("--print-floor-log", &a->floor_log, "FILE",
            "only print the FLOOR and ATTITUDE summary of an LCM log");
  if (const int code = cli.parseOrExit(argc, argv); code >= 0) return code;
  if (a->print_options) {
    std::fputs(cli.optionList().print().c_str(), stdout);
    return 0;
  }
  if (a->synthetic_rides < 0 || !(a->rate_hz > 0) || a->sim_sessions < 0) {
    std::fprintf(
        stderr,
        "evermap-imu-elevator-run: --synthetic and --sim-sessions must be >= 0, --rate > 0\n");
    return 2;
  }
  return -1;
}

// The FLOOR messages in an LCM log (what elevator-proc published), one a line.
int printFloorLog(const std::string& file) {
  messages::LogReader log(file);
  int64_t attitudes = 0, first = 0, last = 0, untrusted = 0;
  while (const messages::LogReader::Event* ev = log.next()) {
    if (ev->channel == channels::kAttitude) {
      auto decoded = messages::decodeLcm<attitude_t>(ev->data, ev->datalen, ev->channel);
      if (!decoded) continue;
      const attitude_t& a = *decoded;
      if (attitudes++ == 0) first = a.utime;
      last = a.utime;
      untrusted += a.accel_trusted ? 0 : 1;
      continue;
    }
    if (ev->channel != channels::kFloor) continue;
    auto decoded = messages::decodeLcm<floor_t>(ev->data, ev->datalen, ev->channel);
    if (!decoded) continue;
    const floor_t& m = *decoded;
    std::printf("FLOOR utime %lld event %s floor %d height %.2f sigma %.2f in_elevator %d new %d\n",
                static_cast<long long>(m.utime), elevator::floorEventName(m.event), m.floor_index,
                m.height_m, m.height_sigma_m, m.in_elevator, m.new_floor);
  }
  if (Status s = log.status(); !s) {  // cut mid-event: the summary would be of part of it
    std::fprintf(stderr, "evermap-imu-elevator-run: %s\n", s.error().message.c_str());
    return 1;
  }
  const double span_s = 1e-6 * static_cast<double>(last - first);
  std::printf("ATTITUDE %lld messages over %.1f s of data: %.1f Hz, %lld with accel untrusted\n",
              static_cast<long long>(attitudes), span_s,
              span_s > 0 ? static_cast<double>(attitudes - 1) / span_s : 0.0,
              static_cast<long long>(untrusted));
  return 0;
}

// The simulator's raw IMU through both filters: does every ride end on the right floor?
int runSimulatorCheck(const Args& args) {
  auto options = sim::loadConfig(sim::loadSimOptions, args.sim_config, args.sim_sets, "--sim-set");
  if (!options.ok()) {
    std::fprintf(stderr, "%s\n", options.error().message.c_str());
    return 1;
  }
  std::printf("simulator: %s, IMU at %.0f Hz, %.1f s around each ride\n", args.sim_config.c_str(),
              options->sensors.imu.rate_hz, options->sensors.imu.margin_s);
  auto check =
      elevator::checkSimulatedFloors(*options, args.attitude, args.elevator, args.sim_sessions);
  if (!check.ok()) {
    std::fprintf(stderr, "%s\n", check.error().message.c_str());
    return 1;
  }
  std::printf("%s%s\nelevator: %s\nfloor table:", check->table().c_str(), check->summary().c_str(),
              check->counts.summary().c_str());
  for (size_t i = 0; i < check->table_heights.size(); ++i) {
    std::printf(" %zu: %.2f m", i, check->table_heights[i]);
  }
  std::printf("\n");
  return 0;
}

// What the input gave: the samples, and a HackZurich session's reference or the synthetic
// run's truth when there is one.
struct Input {
  std::vector<imu::ImuSample> samples;
  datasets::HackzurichSession session;
  elevator::SimulatedRun truth;
};

// `r`'s value, or its error printed and false.
template <typename T>
bool take(Expected<T>&& r, T* out) {
  if (!r.ok()) {
    std::fprintf(stderr, "%s\n", r.error().message.c_str());
    return false;
  }
  *out = std::move(*r);
  return true;
}

// Reads the one input the command line names; -1 on success, else the exit status.
int readInput(const Args& args, Input* in) {
  auto& samples = in->samples;
  if (!args.euroc_imu.empty()) {
    return take(datasets::readEurocImu(args.euroc_imu), &samples) ? -1 : 1;
  }
  if (!args.hackzurich.empty()) {
    if (!take(datasets::readHackzurichSession(args.hackzurich, args.session), &in->session)) {
      return 1;
    }
    const datasets::HackzurichSession& session = in->session;
    samples = session.imu;
    std::printf(
        "session %d: %lld accelerometer rows, %lld without a gyro reading near them, "
        "%zu barometer rows, %zu labelled episodes\n",
        args.session, static_cast<long long>(session.accelerometer_rows),
        static_cast<long long>(session.rows_without_gyro), session.barometer.size(),
        session.episodes.size());
    return -1;
  }
  if (!args.science_journal.empty()) {
    auto r = datasets::readScienceJournalCsv(args.science_journal);
    if (!r.ok()) {
      std::fprintf(stderr, "%s\n", r.error().message.c_str());
      return 1;
    }
    std::printf("%s: %s\n", args.science_journal.c_str(), r->summary().c_str());
    samples = std::move(r->imu);
    return -1;
  }
  if (!args.lcm_log.empty()) {
    auto r = imu::readImuLog(args.lcm_log, args.channel);
    if (!r.ok()) {
      std::fprintf(stderr, "evermap-imu-elevator-run: %s\n", r.error().message.c_str());
      return 1;
    }
    samples = r->samples;
    std::printf("%s: %zu %s messages, %lld undecodable\n", args.lcm_log.c_str(), r->samples.size(),
                args.channel.c_str(), static_cast<long long>(r->undecodable));
    return -1;
  }
  if (args.synthetic_rides > 0) {
    elevator::RideSimulatorOptions o;
    o.rate_hz = args.rate_hz;
    in->truth = elevator::simulateRun(o, elevator::randomScript(o, args.synthetic_rides, 5));
    samples = in->truth.samples;
    std::printf("synthetic building: %zu rides, %zu samples at %.0f Hz\n", in->truth.rides.size(),
                samples.size(), o.rate_hz);
    return -1;
  }
  std::fprintf(stderr,
               "evermap-imu-elevator-run: no input: give --euroc-imu, --hackzurich, --lcm-log, "
               "--synthetic or --sim-config (--help)\n");
  return 2;
}

// The attitude track against EuRoC ground truth, in the IMU, vehicle and level-body frames.
int printAttitudeErrors(const Args& args, const std::vector<imu::ImuSample>& samples,
                        const elevator::OfflineRun& run) {
  const std::vector<imu::Attitude>& track = run.attitudes;
  const auto gt = datasets::readEurocGroundTruth(args.ground_truth);
  if (!gt.ok()) {
    std::fprintf(stderr, "%s\n", gt.error().message.c_str());
    return 1;
  }
  if (gt->empty()) {
    std::fprintf(stderr, "%s: no poses\n", args.ground_truth.c_str());
    return 1;
  }
  // The body stands still for the filter's start-up window (it says so: still_start) and,
  // on EuRoC, a few seconds more: the reference's world z is checked against gravity over
  // the first 2 s both cover.
  const int64_t rest_t0 = std::max(samples.front().utime, messages::utimeFromNs(gt->front().t_ns));
  const double world_tilt = imu::referenceTiltAtRest(samples, *gt, rest_t0, 2.0);
  std::printf(
      "reference world z vs gravity measured at rest (2 s from the start of both): %.2f deg\n",
      world_tilt * 180.0 / M_PI);
  imu::AttitudeCompareOptions c;
  c.max_offset_s = 0.06;
  std::printf("attitude error, IMU frame (its own Euler angles): %s\n",
              imu::compareAttitude(track, *gt, c).summary().c_str());
  if (run.attitude_counts.still_start) {
    // The vehicle frame: the IMU turned by its mounting tilt, read off the accelerometer
    // during the still start-up window (the vehicle stands level on the ground).
    c.vehicle_up_imu =
        imu::meanSpecificForce(samples, samples.front().utime, args.attitude.init_window_s);
    const imu::AttitudeErrorSummary v = imu::compareAttitude(track, *gt, c);
    std::printf(
        "attitude error, vehicle frame (IMU turned by its mounting tilt at rest, %.1f deg): %s\n",
        std::acos(c.vehicle_up_imu.normalized().z()) * 180.0 / M_PI, v.summary().c_str());
    std::printf("EuRoC roll/pitch figure (vehicle frame): roll RMS %.2f deg, pitch RMS %.2f deg\n",
                v.roll_rms_rad * 180.0 / M_PI, v.pitch_rms_rad * 180.0 / M_PI);
    c.vehicle_up_imu.setZero();
  } else {
    std::printf("attitude error, vehicle frame: not available (the start was not still)\n");
  }
  c.level_body = true;
  std::printf("attitude error, level body (mean reference up):  %s\n",
              imu::compareAttitude(track, *gt, c).summary().c_str());
  c.align_gravity = true;
  std::printf("attitude error, level body, world up fit:        %s\n",
              imu::compareAttitude(track, *gt, c).summary().c_str());
  c.align_body = true;
  std::printf("attitude error, level body, world+body fit:      %s\n",
              imu::compareAttitude(track, *gt, c).summary().c_str());
  return 0;
}

// The rides found, beside the barometer, the labelled episodes and the synthetic truth.
void printRides(const Input& in, const elevator::OfflineRun& run) {
  const int64_t origin = in.samples.front().utime;
  const auto rows =
      elevator::ridesWithReference(run.rides, in.session.barometer, in.session.episodes);
  std::printf("\nrides (times from the first sample, disp = elevator, baro = barometer):\n%s",
              elevator::formatRideTable(rows, origin).c_str());
  std::printf("floors:");
  for (size_t i = 0; i < run.floor_heights.size(); ++i)
    std::printf(" %zu: %.2f m", i, run.floor_heights[i]);
  std::printf("\n");
  for (const auto& r : in.truth.rides) {
    std::printf("true ride %.1f..%.1f s  floor %d -> %d  %+.2f m\n", r.start_s - origin * 1e-6,
                r.end_s - origin * 1e-6, r.from_floor, r.to_floor, r.displacement_m);
  }
  for (const auto& r : run.rejected) {
    std::printf("rejected ride %.1f..%.1f s (%+.2f m, peak %.2f m/s): %s\n",
                1e-6 * static_cast<double>(r.start_utime - origin),
                1e-6 * static_cast<double>(r.end_utime - origin), r.displacement_m,
                r.peak_speed_m_s, r.reason.c_str());
  }
  for (const auto& a : run.abandoned) {
    std::printf("abandoned ride start at %.1f s (given up at %.1f s): %s\n",
                1e-6 * static_cast<double>(a.start_utime - origin),
                1e-6 * static_cast<double>(a.abandon_utime - origin), a.reason.c_str());
  }
  for (const auto& e : in.session.episodes) {
    std::printf("episode %-30s %8.1f .. %8.1f s\n", e.label.c_str(),
                1e-9 * static_cast<double>(e.start_ns) - 1e-6 * static_cast<double>(origin),
                1e-9 * static_cast<double>(e.end_ns) - 1e-6 * static_cast<double>(origin));
  }
}

// Written whole or not at all (temporary file + rename): never a half file on failure.
bool writeWhole(const std::string& file, const std::string& text) {
  if (Status s = writeFileAtomically(file, text); !s) {
    std::fprintf(stderr, "evermap-imu-elevator-run: %s\n", s.error().message.c_str());
    return false;
  }
  return true;
}

// --dump-attitude and --dump-trace; false when one could not be written.
bool writeDumps(const Args& args, const elevator::OfflineRun& run,
                const std::vector<elevator::TraceBin>& trace,
                const std::vector<elevator::Pulse>& pulses) {
  if (!args.dump_attitude.empty()) {
    std::ostringstream out;
    for (const auto& a : run.attitudes) {
      out << a.utime << ' ' << a.roll_rad << ' ' << a.pitch_rad << ' ' << a.covariance(0, 0) << ' '
          << a.covariance(1, 1) << ' ' << int(a.accel_trusted) << '\n';
    }
    if (!writeWhole(args.dump_attitude, out.str())) return false;
  }
  if (!args.dump_trace.empty()) {
    std::ostringstream out;
    for (const auto& b : trace) {
      out << b.utime << ' ' << b.accel_m_s2 << ' ' << b.motion_std_m_s2 << ' ' << int(b.valid)
          << ' ' << int(b.riding) << ' ' << b.gravity_m_s2 << ' ' << b.step_rms_m_s2 << ' '
          << int(b.walking) << '\n';
    }
    std::ostringstream pout;
    for (const auto& p : pulses) {
      const int64_t bin_us = static_cast<int64_t>(std::llround(args.elevator.pulse.bin_s * 1e6));
      pout << p.firstBin() * bin_us << ' ' << p.lastBin() * bin_us << ' ' << p.amplitude_m_s2 << ' '
           << p.residual_m_s2 << ' ' << p.snr << ' ' << p.delta_v_m_s << '\n';
    }
    if (!writeWhole(args.dump_trace, out.str()) ||
        !writeWhole(args.dump_trace + ".pulses", pout.str()))
      return false;
  }
  return true;
}

// The samples as the filters take them (the gyro zeroed under --zero-gyro), written to
// --write-lcm-log when asked.
bool filterSamples(const Args& args, const std::vector<imu::ImuSample>& samples,
                   std::vector<imu::ImuSample>* imu_samples) {
  *imu_samples = samples;
  if (args.zero_gyro) {
    for (imu::ImuSample& s : *imu_samples) s.gyro_rad_s.setZero();
  }
  if (args.write_lcm_log.empty()) return true;
  if (Status st = imu::writeImuLog(args.write_lcm_log, args.channel, *imu_samples); !st.ok()) {
    std::fprintf(stderr, "%s\n", st.error().message.c_str());
    return false;
  }
  std::printf("wrote %zu IMU samples to %s\n", imu_samples->size(), args.write_lcm_log.c_str());
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  Args args;
  if (const int code = parse(argc, argv, &args); code >= 0) return code;
  if (!args.floor_log.empty()) return printFloorLog(args.floor_log);
  if (!args.sim_config.empty()) return runSimulatorCheck(args);
  if (args.walking_sweep) {
    std::printf("%s",
                elevator::formatWalkingSweep(elevator::runWalkingSweep(args.elevator)).c_str());
    return 0;
  }
  Input in;
  if (const int code = readInput(args, &in); code >= 0) return code;
  if (in.samples.empty()) {
    std::fprintf(stderr, "evermap-imu-elevator-run: no IMU samples\n");
    return 1;
  }
  std::vector<imu::ImuSample> imu_samples;
  if (!filterSamples(args, in.samples, &imu_samples)) return 1;
  std::vector<elevator::TraceBin> trace;
  std::vector<elevator::Pulse> pulses;
  const bool tracing = !args.dump_trace.empty();
  const elevator::OfflineRun run =
      elevator::runImuElevator(imu_samples, args.attitude, args.elevator, true,
                               tracing ? &trace : nullptr, tracing ? &pulses : nullptr);
  std::printf("attitude: %s\nelevator: %s\n    gate: %s\n", run.attitude_counts.summary().c_str(),
              run.counts.summary().c_str(), run.gate.summary().c_str());
  std::printf("gravity reference at the end: %.3f m/s^2%s\n", run.gravity_m_s2,
              run.gravity_plausible
                  ? ""
                  : "  NOT GRAVITY: is the input gravity-removed? every ride is rejected");
  if (!args.ground_truth.empty() && printAttitudeErrors(args, in.samples, run) != 0) return 1;
  printRides(in, run);
  return writeDumps(args, run, trace, pulses) ? 0 : 1;
}
