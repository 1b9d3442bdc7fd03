#pragma once
// Data-set converters: an EuRoC ASL folder, a KITTI odometry sequence or a TUM RGB-D sequence
// to one LCM log with
// the channels of core/messages/channels.h, every event in time order, so that the whole
// system (or lcm-logplayer) replays a data set as if the sensors were live.
//
//   STEREO_CALIB  stereo_calib_t, first (utime = the earliest stamp of the log), and again
//                 before the first pair of every channels::kCalibrationPeriodS (state, not
//                 an event: docs/contracts.md)
//   STEREO        stereo_image_t per synchronised pair (EuRoC: raw, rectified = 0;
//                 KITTI: rectified = 1), zstd rows (default), PNG or raw gray8
//   IMU           imu_t per row of imu0/data.csv (EuRoC only)
//   GROUND_TRUTH  pose_t world_T_body per ground-truth row (zero covariance, floor and
//                 session -1); KITTI: body = camera 0
//   RGBD          rgbd_image_t per associated color/depth pair (TUM RGB-D), the calibration
//                 inside; gray zstd rows (or PNG) + 16-bit PNG depth, or raw gray8 + raw uint16
//   RGBD_CALIB    rgbd_calib_t, first and before the first frame of every period (TUM RGB-D)
//   ACCEL         accel_t per row of accelerometer.txt (TUM RGB-D)
//   GROUND_TRUTH  TUM RGB-D: world_T_body, body = the color camera
// Events with the same utime are written IMU, GROUND_TRUTH, STEREO: a consumer has the
// inertial data up to an image before the image.

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>

#include "core/common/expected.h"
#include "core/messages/convert.h"
#include "tools/datasets/kitti.h"
#include "tools/datasets/tum_rgbd.h"

namespace evermap::datasets {

struct ConversionSummary {
  std::map<std::string, int64_t> messages;  // per channel
  int64_t bytes = 0;                        // size of the log
  // EuRoC: rows of camN/data.csv whose image file does not exist. KITTI: frames of times.txt
  // skipped because image_0/NNNNNN.png or image_1/NNNNNN.png does not exist.
  int64_t skipped_missing_image = 0;
  // EuRoC: stamps with an image in one camera only (after the missing files are dropped).
  int64_t skipped_unpaired = 0;
  std::string ground_truth;  // the file the poses came from; empty when there were none

  // A few plain lines: per-channel counts, what was skipped, the ground-truth source.
  std::string report() const;
};

struct EurocToLcmOptions {
  messages::ImageEncoding encoding = messages::ImageEncoding::kZstd;
  // Ground truth, EuRoC CSV ("t[ns], p xyz, q wxyz, ...") or TUM text (.txt). Empty: use
  // mav0/state_groundtruth_estimate0/data.csv when it exists, else write no ground truth.
  std::filesystem::path ground_truth;

  Status validate() const;
};

// `asl_folder` is the folder holding mav0/ (mav0 itself is accepted too). Errors name the
// file: a calibration that does not validate, a corrupt or unreadable image, an image whose
// size differs from the calibration. Nothing is left at `output` on failure.
Expected<ConversionSummary> convertEurocToLcm(const std::filesystem::path& asl_folder,
                                              const std::filesystem::path& output,
                                              const EurocToLcmOptions& options);

struct KittiToLcmOptions {
  messages::ImageEncoding encoding = messages::ImageEncoding::kZstd;
  // Folders, frame rate, ground truth (tools/datasets/kitti.h).
  KittiSequenceOptions sequence;
  // The images' disparity offset (pixels) against calib.txt, written into STEREO_CALIB as the
  // right camera's cx = left cx + disparity_offset_px (core::withDisparityOffset), so that every
  // receiver of the log corrects its depths (d = measured + offset). kitti-stereo-clip: +0.8
  // (evermap-stereo-check --self-offset, docs/vo.md). At most a quarter of the image width.
  double disparity_offset_px = 0.0;

  Status validate() const;
};

// `sequence` as readKittiSequence() takes it (kitti.h): image folders, calib.txt (labelled or
// not), times.txt or a rate, poses.txt when present. Its errors, and an image whose size
// differs from the first one's.
Expected<ConversionSummary> convertKittiToLcm(const std::filesystem::path& sequence,
                                              const std::filesystem::path& output,
                                              const KittiToLcmOptions& options);

struct TumToLcmOptions {
  messages::ImageEncoding encoding = messages::ImageEncoding::kZstd;
  // One of tumCalibration()'s names; empty: tumCalibrationNameFor(the folder).
  std::string calibration;
  TumRgbdOptions sequence;              // the association limit
  double depth_scale_m = 1.0 / 5000.0;  // TUM's depth unit

  Status validate() const;
};

// A TUM RGB-D folder (tum_rgbd.h) to a log: every associated pair one RGBD message (stamped
// with the color image; its depth stamp inside), ground truth and accelerometer when present.
// Color images are converted to gray (OpenCV's 0.299 R + 0.587 G + 0.114 B), gray ones taken
// as they are. Errors name the file: an image that does not decode, a depth image that is
// not 16-bit one-channel or not of the calibration's size. Unassociated color images are
// counted (skipped_unpaired), not errors.
Expected<ConversionSummary> convertTumRgbdToLcm(const std::filesystem::path& sequence,
                                                const std::filesystem::path& output,
                                                const TumToLcmOptions& options);

}  // namespace evermap::datasets
