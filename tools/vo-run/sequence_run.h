#pragma once
// Visual odometry over a folder of rectified stereo pairs in the KITTI odometry layout
// (tools/datasets/kitti.h: image_0/image_1 or image_l/image_r, calib.txt, times.txt or a rate,
// poses.txt), read straight from the PNG files, without LCM, and its error against the
// folder's ground truth. What the KITTI tests and the benchmark share.
//
// Poses are chained from the frames' VO_DELTA messages exactly as the offline runner does
// (vo_trajectory.h), in the frame of the left camera at the first frame, which is also the
// frame of KITTI's ground truth (world_T_cam0, identity at frame 0).
//
// Error measures (tools/eval/metrics.h):
//  - end error: the last posed frame against its ground truth, without alignment (both start
//    at the identity): translation in metres and in % of the ground-truth path length,
//    rotation in degrees;
//  - ATE after an SE(3) Umeyama alignment of the posed frames;
//  - RPE over one frame, its mean translation also as % of the mean ground-truth step.
// The pairs go through vo-proc's VoPipeline as rectified frames (its start-up hold included:
// frames may be processed twice). Time per frame is the CPU time of the calling thread in
// VoPipeline::handleFrame (image decoding excluded), the measure of bench/vo_bench.cpp; the
// frame that ends the hold carries the held frames' second pass.

#include <filesystem>
#include <string>
#include <vector>

#include "core/common/expected.h"
#include "core/geometry/se3.h"
#include "tools/datasets/kitti.h"
#include "vo-proc/stereo_odometry.h"

namespace evermap::vo {

struct SequenceRunOptions {
  OdometryOptions odometry;
  double startup_hold_s = 3.0;  // PipelineOptions::startup_hold_s
  datasets::KittiSequenceOptions sequence;
  // The images' disparity offset against calib.txt (pixels), made part of the calibration as
  // evermap-kitti2lcm --disparity-offset does (right cx = left cx + offset); 0: calib.txt's.
  double disparity_offset_px = 0.0;
  int max_frames = -1;  // -1: all

  Status validate() const;
};

struct SequenceRun {
  std::vector<FrameResult> frames;  // keyframe payloads dropped
  std::vector<double> cpu_ms;       // per frame
  std::vector<core::SE3d> gt, est;  // world_T_cam of the posed frames with ground truth
  int posed = 0;                    // frames with a pose (OK, first frame, bridged)
  int keyframes = 0;
  double path_length_m = 0.0;  // of the ground truth over the posed frames
  double end_error_m = 0.0;
  double end_error_percent = 0.0;
  double end_rotation_deg = 0.0;
  double ate_rmse_m = 0.0;
  double rpe_percent = 0.0;   // mean per-frame translation error / mean step
  double rpe_deg = 0.0;       // mean per-frame rotation error
  double mean_inliers = 0.0;  // over the frames registered (OK)
  double median_ms = 0.0, p90_ms = 0.0, p99_ms = 0.0;

  // A few lines with every figure above.
  std::string report() const;
};

// Errors: the folder (readKittiSequence), an image that does not load, invalid options, no
// ground truth, fewer than 3 posed frames.
Expected<SequenceRun> runKittiSequence(const std::filesystem::path& folder,
                                       const SequenceRunOptions& options);

}  // namespace evermap::vo
