#include "tools/vo-run/offline_runner.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <sstream>
#include <utility>

#include "core/common/atomic_write.h"
#include "core/common/percentile.h"
#include "core/messages/channels.h"
#include "core/messages/convert.h"
#include "tools/lcmlog/log_reader.h"
#include "tools/lcmlog/log_writer.h"
#include "tools/vo-run/vo_trajectory.h"

namespace evermap::vo {

std::map<std::string, int> OfflineSummary::failuresByKind() const {
  std::map<std::string, int> n;
  for (const FrameStats& f : frames) {
    if (f.failure_kind.empty()) continue;
    ++n[(f.bridged ? "bridged after " : std::string(toString(f.status)) + ": ") + f.failure_kind];
  }
  return n;
}

std::string OfflineSummary::report() const {
  std::ostringstream s;
  int bridged = 0, via_previous = 0, fast_motion = 0;
  for (const FrameStats& f : frames) {
    bridged += f.bridged ? 1 : 0;
    via_previous += f.via_previous ? 1 : 0;
    fast_motion += f.fast_motion ? 1 : 0;
  }
  s << stats.report() << "\n"
    << trajectory.size() << " poses, path length " << trajectory.pathLengthM() << " m, " << breaks
    << " chain breaks, " << bridged << " frames bridged by the motion prior, " << via_previous
    << " registered through the previous frame, " << fast_motion
    << " registered by the fast-motion retry\n";
  const auto kinds = failuresByKind();
  if (kinds.empty()) {
    s << "failures: none\n";
  } else {
    s << "failures by kind:";
    for (const auto& [kind, n] : kinds) s << " " << kind << " " << n << ";";
    s << "\n";
  }
  s << "self-calibration: " << (self_calibration.empty() ? "undecided" : self_calibration) << "\n";
  s << "per frame: median " << median_ms << " ms, p90 " << p90_ms << " ms, p99 " << p99_ms << " ms";
  return s.str();
}

std::string OfflineSummary::verboseReport() const {
  std::ostringstream s;
  for (size_t k = 0; k < frames.size(); ++k) {
    const FrameStats& f = frames[k];
    if (f.status == VoStatus::kOk && !f.bridged && !f.via_previous && !f.fast_motion) continue;
    s << "frame " << k << " (" << f.utime << "): " << (f.bridged ? "bridged" : toString(f.status));
    if (!f.failure_kind.empty()) s << " [" << f.failure_kind << "]";
    s << ": " << f.message << "\n";
  }
  return s.str();
}

namespace {

// A STEREO_CALIB event with its disparity offset replaced (OfflineOptions::disparity_offset_px).
Expected<evermap::stereo_calib_t> overrideDisparityOffset(const void* data, int64_t size,
                                                          double offset_px) {
  auto msg = messages::decodeLcm<evermap::stereo_calib_t>(data, size, "STEREO_CALIB");
  if (!msg) return msg.error();
  auto calibration = messages::fromMsg(*msg);
  if (!calibration) return calibration.error();
  auto offset = core::withDisparityOffset(*calibration, offset_px);
  if (!offset) return makeError("--disparity-offset: ", offset.error().message);
  return messages::toMsg(*offset, msg->utime);
}

// A STEREO_CALIB event into the pipeline (with the options' disparity offset). Errors: the
// offset does not apply; the pipeline's own refusals are printed and the run goes on.
Status handleCalibration(VoPipeline& pipeline, const messages::LogReader::Event& event,
                         const OfflineOptions& options) {
  Status s = Ok{};
  if (options.disparity_offset_px) {
    auto msg = overrideDisparityOffset(event.data, event.datalen, *options.disparity_offset_px);
    if (!msg) return msg.error();
    s = pipeline.handleCalibration(*msg);
  } else {
    s = pipeline.handleCalibrationBytes(event.data, event.datalen);
  }
  if (!s) std::fprintf(stderr, "vo: %s\n", s.error().message.c_str());
  return Ok{};
}

// The CSV row of one frame's result, processed in `ms`.
FrameStats frameStats(const FrameResult& r, double ms) {
  FrameStats f;
  f.utime = r.utime;
  f.status = r.status;
  f.keyframe_changed = r.keyframe_changed;
  f.num_corners = r.num_corners;
  f.num_features = r.num_features;
  f.num_matches = r.num_matches;
  f.num_inliers = r.num_inliers;
  f.mean_reprojection_px = r.mean_reprojection_px;
  f.delta_translation_m = r.ok() ? r.ref_T_cur.translation().norm() : 0.0;
  f.process_ms = ms;
  f.bridged = r.bridged;
  f.via_previous = r.via_previous;
  f.fast_motion = r.fast_motion;
  f.failure_kind = r.failure_kind;
  f.message = r.message;
  return f;
}

// VO_DELTA and, for a new keyframe, KEYFRAME into the output log.
Status writeOutput(messages::LogWriter& writer, const PipelineOutput& out) {
  const int64_t utime = out.result.utime;
  if (Status s = writer.write(channels::kVoDelta, utime, out.delta); !s) return s;
  if (out.keyframe) {
    if (Status s = writer.write(channels::kKeyframe, utime, *out.keyframe); !s) return s;
  }
  if (out.calibration) return writer.write(channels::kVoCalib, utime, *out.calibration);
  return Ok{};
}

}  // namespace

Expected<OfflineSummary> runOffline(const std::filesystem::path& log,
                                    const OfflineOptions& options) {
  auto pipeline = VoPipeline::create(options.pipeline);
  if (!pipeline) return pipeline.error();
  auto opened = messages::LogReader::open(log);
  if (!opened) return opened.error();
  messages::LogReader& file = *opened;
  std::optional<messages::LogWriter> writer;
  if (!options.output_log.empty()) {
    auto w = messages::LogWriter::open(options.output_log);
    if (!w) return w.error();
    writer.emplace(std::move(*w));
  }

  OfflineSummary summary;
  summary.trajectory.source = log.string() + " (visual odometry)";
  VoTrajectory chain;
  std::vector<double> times;
  int64_t frames = 0;
  // One output: its row, its pose, its messages.
  auto take = [&](const PipelineOutput& out, double ms) -> Status {
    const FrameResult& r = out.result;
    if (!r.calibration_message.empty()) {
      if (!summary.self_calibration.empty()) summary.self_calibration += "\n  ";
      summary.self_calibration +=
          "frame " + std::to_string(summary.frames.size() + 1) + ": " + r.calibration_message;
    }
    summary.frames.push_back(frameStats(r, ms));
    if (auto cam0_T_cam = chain.add(out.delta)) {
      core::SE3d pose = *cam0_T_cam;
      if (options.body_frame) {
        const core::SE3d& B = pipeline->bodyTCamera();
        pose = B * pose * B.inverse();
      }
      summary.trajectory.poses.push_back({messages::nsFromUtime(r.utime), pose});
    }
    return writer ? writeOutput(*writer, out) : Status{Ok{}};
  };
  while (const messages::LogReader::Event* event = file.next()) {
    const std::string& channel = event->channel;
    if (channel == channels::kStereoCalib) {
      if (Status s = handleCalibration(*pipeline, *event, options); !s) return s.error();
      continue;
    }
    const bool rgbd = channel == channels::kRgbd;
    if (channel != channels::kStereo && !rgbd) continue;
    if (options.max_frames >= 0 && frames >= options.max_frames) break;
    ++frames;
    const auto start = std::chrono::steady_clock::now();
    auto outs = rgbd ? pipeline->handleRgbdBytes(event->data, event->datalen)
                     : pipeline->handleStereoBytes(event->data, event->datalen);
    const double ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    if (!outs) {
      std::fprintf(stderr, "vo: event %lld: %s\n", static_cast<long long>(event->eventnum),
                   outs.error().message.c_str());
      continue;
    }
    times.push_back(ms);
    // The input's time goes on the last output it released (its own frame); a frame the
    // start-up hold released with it has 0.
    for (size_t i = 0; i < outs->size(); ++i) {
      if (Status s = take((*outs)[i], i + 1 == outs->size() ? ms : 0.0); !s) return s.error();
    }
  }
  for (const PipelineOutput& out : pipeline->flush()) {
    if (Status s = take(out, 0.0); !s) return s.error();
  }
  // A log cut mid-event (or damaged) gives a trajectory of part of the data: an error, and
  // the output log is not committed.
  if (Status s = file.status(); !s) return s.error();
  if (writer) {
    if (Status s = writer->commit(); !s) return s.error();
  }
  summary.stats = pipeline->stats();
  summary.breaks = chain.breaks();
  summary.median_ms = percentile(times, 0.5);
  summary.p90_ms = percentile(times, 0.9);
  summary.p99_ms = percentile(times, 0.99);
  summary.line_delay_left_over = pipeline->lineDelayLeftOver();
  return summary;
}

AngularVelocities angularVelocities(const eval::Trajectory& camera_trajectory) {
  AngularVelocities omega;
  const std::vector<eval::StampedPose>& poses = camera_trajectory.poses;
  for (size_t k = 0; k < poses.size(); ++k) {
    // The frames on both sides (one side at the ends).
    const eval::StampedPose& a = poses[k == 0 ? 0 : k - 1];
    const eval::StampedPose& b = poses[std::min(k + 1, poses.size() - 1)];
    const double dt_s = 1e-9 * static_cast<double>(b.t_ns - a.t_ns);
    if (!(dt_s > 0.0)) continue;
    const core::SO3d a_R_b = a.world_T_body.so3().inverse() * b.world_T_body.so3();
    omega[messages::utimeFromNs(poses[k].t_ns)] = a_R_b.log() / dt_s;
  }
  return omega;
}

Expected<LineDelayCalibration> calibrateLineDelay(const std::filesystem::path& log,
                                                  OfflineOptions options, int max_runs) {
  options.pipeline.odometry.gather_line_delay_evidence = true;
  double& delay = options.pipeline.odometry.line_delay_us;
  // The runs' trajectories give the next run's angular velocities in the camera's frame; with
  // --body the last delay is run once more for the body's.
  const bool body_frame = std::exchange(options.body_frame, false);
  LineDelayCalibration calibration;
  for (int run = 1;; ++run) {
    auto summary = runOffline(log, options);
    if (!summary) return summary.error();
    const std::optional<core::CurveEstimate>& left = summary->line_delay_left_over;
    if (!left || !std::isfinite(left->standard_error)) {
      return makeError(log.string(), ": line delay: no estimate at ", delay, " us per row (",
                       left ? left->pairs_informative : 0, " informative pairs of ",
                       left ? left->pairs_examined : 0,
                       "; the camera must turn, and its frames register)");
    }
    char line[200];
    std::snprintf(line, sizeof(line),
                  "line delay run %d: %.1f us per row, %+.1f +- %.1f us left (%d pairs of %d "
                  "frames, %d examined)",
                  run, delay, left->value, left->standard_error, left->pairs_used,
                  left->groups_used, left->pairs_examined);
    calibration.runs.push_back(line);
    // Settled: nothing significant left, or only a negative delay would take it.
    const double next = std::max(0.0, delay + left->value);
    if (std::abs(left->value) <= std::max(0.25 * left->standard_error, 1.0) || next == delay) {
      calibration.line_delay_us = delay;
      calibration.standard_error_us = left->standard_error;
      if (body_frame) {
        options.body_frame = true;
        options.pipeline.odometry.gather_line_delay_evidence = false;
        summary = runOffline(log, options);
        if (!summary) return summary.error();
      }
      calibration.summary = std::move(*summary);
      return calibration;
    }
    if (run >= max_runs) {
      return makeError(log.string(), ": line delay: not settled after ", max_runs, " runs (", delay,
                       " us per row, ", left->value, " us left)");
    }
    delay = next;
    options.pipeline.odometry.line_delay_angular_velocity =
        std::make_shared<const AngularVelocities>(angularVelocities(summary->trajectory));
  }
}

Status writeFrameStatsCsv(const std::vector<FrameStats>& frames,
                          const std::filesystem::path& file) {
  std::ostringstream s;
  s << "utime,status,keyframe_changed,corners,features,matches,inliers,mean_reprojection_px,"
       "delta_translation_m,process_ms,bridged,failure_kind,message\n";
  for (const FrameStats& f : frames) {
    std::string message = f.message;
    std::replace(message.begin(), message.end(), ',', ';');
    std::replace(message.begin(), message.end(), '\n', ' ');
    char numbers[160];
    std::snprintf(numbers, sizeof(numbers), "%.4f,%.6f,%.3f", f.mean_reprojection_px,
                  f.delta_translation_m, f.process_ms);
    s << f.utime << "," << toString(f.status) << "," << (f.keyframe_changed ? 1 : 0) << ","
      << f.num_corners << "," << f.num_features << "," << f.num_matches << "," << f.num_inliers
      << "," << numbers << "," << (f.bridged ? 1 : 0) << "," << f.failure_kind << "," << message
      << "\n";
  }
  return writeFileAtomically(file, s.str());
}

}  // namespace evermap::vo
