#pragma once
// Visual odometry over a recorded LCM log in one process (DESIGN.md section 1, "tools/: the
// offline runner"): every STEREO_CALIB and STEREO event, in log order, goes through the same
// VoPipeline as vo-proc, with no queue and no dropping, so the same log always gives the same
// result. RGBD frames (an RGB-D camera, its calibration inside) are processed the same way.
// Produces the trajectory (camera or body frame, TUM-ready), per-frame statistics and,
// optionally, a log of the VO_DELTA and KEYFRAME messages vo-proc would have published.

#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/common/expected.h"
#include "tools/eval/trajectory.h"
#include "vo-proc/vo_pipeline.h"

namespace evermap::vo {

struct OfflineOptions {
  PipelineOptions pipeline;
  // Poses of the body (IMU) frame, via body_T_cam of the calibration, instead of the
  // rectified left camera: body0_T_body = B * cam0_T_cam * B⁻¹. For comparing with EuRoC
  // ground truth (which is of the body).
  bool body_frame = false;
  int64_t max_frames = -1;           // stop after this many STEREO or RGBD events; -1: all
  std::filesystem::path output_log;  // empty: none
  // Replaces the disparity offset of every rectified STEREO_CALIB of the log (its right cx
  // becomes left cx + this, core::withDisparityOffset) before the pipeline sees it
  // (evermap-vo-run --disparity-offset). Unset: the log's calibration as it is. A raw
  // calibration with it set is an error: its rectification decides the principal points.
  std::optional<double> disparity_offset_px;
};

struct FrameStats {
  int64_t utime = 0;
  VoStatus status = VoStatus::kBadInput;
  bool keyframe_changed = false;
  int num_corners = 0;
  int num_features = 0;
  int num_matches = 0;
  int num_inliers = 0;
  double mean_reprojection_px = 0.0;
  double delta_translation_m = 0.0;  // |ref_T_cur translation|
  double process_ms = 0.0;           // wall time of the frame (a measurement, not an input)
  bool bridged = false;              // kOk by the motion prior (FrameResult::bridged)
  bool via_previous = false;         // kOk through the previous frame
  bool fast_motion = false;          // kOk by the fast-motion retry (widened bounds)
  std::string failure_kind;          // FrameResult::failure_kind
  std::string message;
};

struct OfflineSummary {
  eval::Trajectory trajectory;  // frames with a pose
  std::vector<FrameStats> frames;
  PipelineStats stats;
  int breaks = 0;  // chain breaks bridged (vo_trajectory.h)
  double median_ms = 0.0;
  double p90_ms = 0.0;
  double p99_ms = 0.0;
  // Self-calibration's decision and the frame it came at (empty: none).
  std::string self_calibration;
  // With pipeline.odometry.gather_line_delay_evidence: what is left of the line delay.
  std::optional<core::CurveEstimate> line_delay_left_over;

  // Frames that did not register, counted by FrameResult::failure_kind (bridged frames by
  // the kind of failure that made the bridge needed).
  std::map<std::string, int> failuresByKind() const;
  // The counts, path, breaks, failures by kind and time per frame (median, p90, p99).
  std::string report() const;
  // One line per frame that is not a plain kOk: "frame N (utime): status: message".
  std::string verboseReport() const;
};

// Errors: the log cannot be opened, or the options are invalid. Frames that fail are in the
// summary, not errors.
Expected<OfflineSummary> runOffline(const std::filesystem::path& log,
                                    const OfflineOptions& options);

// A rolling shutter's line delay estimated from the images (docs/rgbd.md, "Rolling shutter"):
// the odometry run again and again, each run's line delay moved by what its registered pairs
// say is left of it (pipeline.odometry.gather_line_delay_evidence), until that is within a
// quarter of its standard error, or 1 us, of 0 (or only a negative delay would take it): the
// delay at which the pairs' evidence says nothing is left (each run's estimate leans towards the
// delay it ran with, so one run's is not the answer). Starts from
// options.pipeline.odometry.line_delay_us. From the second run on, the pairs are judged with the
// angular velocities of the run before's trajectory, differenced on both sides of each frame
// (angularVelocities), not with the motion prior's the features were corrected with.
struct LineDelayCalibration {
  double line_delay_us = 0.0;
  double standard_error_us = 0.0;  // the last run's jackknife
  std::vector<std::string> runs;   // one line per run
  OfflineSummary summary;          // the last run's, at line_delay_us
};
// Errors: those of runOffline; a run without an estimate (the camera did not turn, or too few
// frames registered); no settled delay after max_runs runs.
Expected<LineDelayCalibration> calibrateLineDelay(const std::filesystem::path& log,
                                                  OfflineOptions options, int max_runs = 12);

// Each pose's angular velocity (rad/s, in its own frame; the key: its utime) from the poses on
// both sides of it (one side at the ends): log(R_before⁻¹ R_after) over their interval. Across a
// chain break (VoTrajectory puts the new reference at the last pose) the turn is lost, and a
// frame without a pose keeps its own velocity; neither happens on the TUM excerpt.
AngularVelocities angularVelocities(const eval::Trajectory& camera_trajectory);

// Per-frame statistics as CSV (a header line, one line per frame), written atomically.
Status writeFrameStatsCsv(const std::vector<FrameStats>& frames, const std::filesystem::path& file);

}  // namespace evermap::vo
