#pragma once
// What vo-proc does with its messages, without LCM transport (so the offline runner and the
// tests run the very same code): STEREO_CALIB sets up the camera (raw calibrations are
// rectified with core::StereoRectifier), each STEREO pair is decoded, rectified when raw and
// given to StereoOdometry; the result becomes one vo_delta_t and, when the frame is a new
// keyframe, one keyframe_t.
//
// The start-up hold (startup_hold.h; stereo with self-calibration on): a camera's first frames
// are kept until self-calibration's first decision, or for startup_hold_s of message time, and
// when that decision corrects the camera they are processed again with it before they are
// released. So one frame may release no output (held) or several (the held ones, oldest first);
// flush() releases what is held at the end of the input.
//
// RGBD frames carry their calibration: the first one, and any whose camera differs from the
// current one, sets up (or restarts) odometry with the camera's equivalent stereo rig
// (core/camera/rgbd_camera.h); the images are undistorted and given to
// StereoOdometry::processRgbd. A stereo calibration replaces an RGB-D camera and the reverse.
//
// Every frame that can be decoded gets a vo_delta_t, bad ones with STATUS_BAD_INPUT (and a
// one-line reason): no valid calibration yet (e.g. NaN intrinsics), images of the wrong size,
// an image that does not decode, a raw pair announced as rectified or the reverse; for RGBD,
// a depth of the wrong size or type, an invalid depth scale or calibration, a depth stamp too
// far from the image's (messages/rgbd_convert.h).

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <evermap/keyframe_t.hpp>
#include <evermap/rgbd_image_t.hpp>
#include <evermap/stereo_calib_t.hpp>
#include <evermap/stereo_image_t.hpp>
#include <evermap/vo_delta_t.hpp>

#include "core/camera/calibration.h"
#include "core/camera/rgbd_camera.h"
#include "core/camera/stereo_rectifier.h"
#include "core/common/expected.h"
#include "core/messages/channels.h"
#include "core/messages/convert.h"
#include "core/messages/odometry_frame.h"
#include "core/messages/rgbd_convert.h"
#include "vo-proc/pipeline_output.h"
#include "vo-proc/startup_hold.h"
#include "vo-proc/stereo_odometry.h"

namespace evermap::vo {

struct PipelineOptions {
  OdometryOptions odometry;
  core::StereoRectifier::Options rectifier;
  core::RgbdCamera::Options rgbd;  // the depth noise model of RGB-D cameras
  // With an RGB-D camera, the motion estimate's inlier and acceptance thresholds (they replace
  // odometry.registration.motion's 1 px and 1.5 px): the Kinect's color camera has a rolling
  // shutter, its frames blur at the rotation rates of hand-held motion, and the registered
  // depth is off by a pixel at edges. On the TUM excerpt (docs/rgbd.md) 1 px left 10 of 150
  // frames unregistered and doubled the ATE; 2 px left 4.
  double rgbd_inlier_max_reprojection_px = 2.0;
  double rgbd_max_mean_reprojection_px = 2.0;
  // With an RGB-D camera, odometry.fast_motion_fraction (the retry of a frame that fails at
  // fast rotation with bounds widened for its image motion; stereo_odometry.h): the Kinect's
  // rolling shutter and blur. 0: off.
  double rgbd_fast_motion_fraction = 0.15;
  // Stereo with self-calibration: a camera's first frames are held up to this long (message
  // time) for self-calibration's first decision, and processed again with the calibration it
  // applies; VO's first outputs come that much late. 0: off (the frames before the decision
  // keep the calibration they came with).
  double startup_hold_s = 3.0;

  Status validate() const;
  void declareOptions(OptionList& o) {
    o.add("rgbd_inlier_max_reprojection_px", &rgbd_inlier_max_reprojection_px, "px",
          "RGB-D: a match within this reprojection error is an inlier")
        .positive();
    o.add("rgbd_max_mean_reprojection_px", &rgbd_max_mean_reprojection_px, "px",
          "RGB-D: a motion's mean inlier error at most")
        .positive();
    o.add("rgbd_fast_motion_fraction", &rgbd_fast_motion_fraction, "",
          "RGB-D: a frame failing at fast rotation is retried with bounds widened to this "
          "fraction of its predicted image motion (0: off)")
        .nonNegative();
    o.add("startup_hold_s", &startup_hold_s, "s",
          "stereo: the first frames held for self-calibration's first decision, and processed "
          "again with the calibration it applies (0: off)")
        .nonNegative();
    o.nest("odometry.", &odometry);
    o.nest("rectifier.", &rectifier);
    o.nest("rgbd.", &rgbd);
  }
};

// Counts since the start, per status and of what was refused.
struct PipelineStats {
  int64_t frames = 0;
  std::array<int64_t, 7> by_status{};  // indexed by VoStatus
  int64_t keyframes = 0;
  int64_t calibrations = 0;  // accepted
  int64_t calibrations_refused = 0;
  int64_t undecodable = 0;  // messages that could not be decoded at all

  std::string report() const;
};

class VoPipeline {
 public:
  // Refuses invalid options.
  static Expected<VoPipeline> create(const PipelineOptions& options);

  // A calibration message. The same calibration again changes nothing; a different valid one
  // restarts odometry with the new camera; an invalid one is refused (the error names the
  // field) and leaves the pipeline without a camera, so frames get STATUS_BAD_INPUT until a
  // valid one arrives.
  Status handleCalibration(const evermap::stereo_calib_t& msg);
  // The same from the bytes of an LCM event.
  Status handleCalibrationBytes(const void* data, int64_t size);

  // One stereo pair.
  PipelineOutputs handleStereo(const evermap::stereo_image_t& msg);
  // The same, with the images already decoded (messages::fromMsg of the message at `utime`,
  // or its error): decoding can run ahead on another thread.
  PipelineOutputs handleFrame(int64_t utime, const Expected<messages::StereoFrame>& frame);
  // From the bytes of an LCM event; an error (nothing to publish) when they do not decode.
  Expected<PipelineOutputs> handleStereoBytes(const void* data, int64_t size);

  // One RGB-D frame (its calibration inside).
  PipelineOutputs handleRgbd(const evermap::rgbd_image_t& msg);
  // The same, decoded (messages::fromMsg of the message at `utime`, or its error).
  PipelineOutputs handleRgbdFrame(int64_t utime, const Expected<messages::RgbdFrame>& frame);
  // From the bytes of an LCM event; an error (nothing to publish) when they do not decode.
  Expected<PipelineOutputs> handleRgbdBytes(const void* data, int64_t size);
  // The end of the input: what the start-up hold still keeps, as it is.
  PipelineOutputs flush();
  // The RGB-D camera, when the current camera is one.
  const std::optional<core::RgbdCamera>& rgbdCamera() const { return rgbd_; }

  bool hasCamera() const { return odometry_.has_value(); }
  // The rectified camera; precondition hasCamera().
  const core::StereoCamera& camera() const { return odometry_->camera(); }
  // body_T_cam of the rectified left camera (the frame VO poses are in); identity without a
  // camera.
  const core::SE3d& bodyTCamera() const { return body_T_cam_; }
  // What the registered pairs say is left of the line delay (StereoOdometry).
  std::optional<core::CurveEstimate> lineDelayLeftOver() const {
    return odometry_ ? odometry_->lineDelayLeftOver() : std::nullopt;
  }
  const PipelineStats& stats() const { return stats_; }
  const PipelineOptions& options() const { return options_; }

 private:
  explicit VoPipeline(const PipelineOptions& options) : options_(options) {}
  PipelineOutputs badInput(int64_t utime, const std::string& why);
  // A result as an output (its keyframe message made with the camera of the moment).
  PipelineOutput finish(const FrameResult& result);
  // An output leaving the pipeline: stamped with its odometry pose, VO_CALIB when due, counted.
  PipelineOutput publish(PipelineOutput out);
  // An output through the start-up hold (left, right: the pair it was made from, when one was
  // processed), with whatever was released before it.
  PipelineOutputs emit(PipelineOutput out, const cv::Mat& left = {}, const cv::Mat& right = {});
  // The hold ended: its frames, processed again after a correction, appended to *outs.
  void endHold(PipelineOutputs* outs);
  // The camera changes: what is held is released as it is (returned by the next output).
  void releaseHeld();
  // The VO_CALIB of a stereo camera whose self-calibration has decided, when due.
  std::optional<evermap::stereo_calib_t> calibrationDue(const FrameResult& result);

  PipelineOptions options_;
  std::optional<core::StereoCalibration> calibration_;  // as received
  std::optional<core::StereoRectifier> rectifier_;      // raw calibrations only
  std::optional<StereoOdometry> odometry_;
  std::optional<core::RgbdCamera> rgbd_;  // RGB-D mode only
  cv::Mat rgbd_gray_, rgbd_depth_;        // undistorted buffers
  std::string no_camera_reason_ = "no calibration received yet (STEREO_CALIB)";
  core::SE3d body_T_cam_;
  // Stamps every VO_DELTA with its pose in the odometry frame (odom_*): a new camera restarts
  // the chain (NO_DATA), and with it the epoch.
  messages::OdometryFrame odometry_frame_;
  channels::CalibrationRepeat calibration_repeat_;  // VO_CALIB
  bool calibration_decided_ = false;                // self-calibration decided once
  StartupHold hold_;
  PipelineOutputs released_;  // released by a camera change, not yet returned
  PipelineStats stats_;
};

// The vo_delta_t of a result.
evermap::vo_delta_t toMsg(const FrameResult& result);

}  // namespace evermap::vo
