#include "vo-proc/vo_pipeline.h"

#include <sstream>
#include <string>
#include <utility>

#include "core/messages/convert.h"
#include "core/messages/keyframe_convert.h"
#include "core/messages/pose_fields.h"

namespace evermap::vo {

Status PipelineOptions::validate() const {
  if (Status s = checkOptionRanges(*this); !s) return s;
  if (Status s = odometry.validate(); !s) return s;
  if (Status s = rgbd.validate(); !s) return s;
  return rectifier.validate();
}

std::string PipelineStats::report() const {
  std::ostringstream s;
  s << frames << " frames:";
  for (int i = 0; i < static_cast<int>(by_status.size()); ++i) {
    if (by_status[static_cast<size_t>(i)] == 0) continue;
    s << " " << toString(static_cast<VoStatus>(i)) << " " << by_status[static_cast<size_t>(i)]
      << ",";
  }
  s << " keyframes " << keyframes << ", calibrations " << calibrations << " (refused "
    << calibrations_refused << "), undecodable messages " << undecodable;
  return s.str();
}

Expected<VoPipeline> VoPipeline::create(const PipelineOptions& options) {
  if (Status s = options.validate(); !s) return s.error();
  return VoPipeline(options);
}

namespace {

// Whether two calibrations are the same (utime aside): compared by their encoded messages.
bool sameCalibration(const core::StereoCalibration& a, const core::StereoCalibration& b) {
  auto bytes = [](const core::StereoCalibration& c) {
    const evermap::stereo_calib_t m = messages::toMsg(c, 0);
    std::vector<uint8_t> out(static_cast<size_t>(m.getEncodedSize()));
    m.encode(out.data(), 0, static_cast<int>(out.size()));
    return out;
  };
  return bytes(a) == bytes(b);
}

}  // namespace

Status VoPipeline::handleCalibration(const evermap::stereo_calib_t& msg) {
  // A refused calibration leaves no camera: better no odometry than odometry with the wrong
  // geometry.
  auto refuse = [this](const std::string& why) -> Status {
    releaseHeld();
    ++stats_.calibrations_refused;
    calibration_.reset();
    rectifier_.reset();
    odometry_.reset();
    rgbd_.reset();
    no_camera_reason_ = "calibration refused: " + why;
    return Error{no_camera_reason_};
  };
  auto calibration = messages::fromMsg(msg);
  if (!calibration) return refuse(calibration.error().message);
  if (calibration_ && odometry_ && sameCalibration(*calibration_, *calibration)) return Ok{};
  std::optional<core::StereoRectifier> rectifier;
  Expected<core::StereoCamera> camera = Error{"no camera"};
  core::SE3d body_T_cam;
  if (calibration->rectified) {
    camera = core::rectifiedStereoCamera(*calibration);
    body_T_cam = calibration->left.body_T_cam;
  } else {
    auto r = core::StereoRectifier::create(*calibration, options_.rectifier);
    if (!r) return refuse(r.error().message);
    rectifier.emplace(std::move(*r));
    camera = rectifier->camera();
    body_T_cam = rectifier->rectifiedCalibration().left.body_T_cam;
  }
  if (!camera) return refuse(camera.error().message);
  auto odometry = StereoOdometry::create(*camera, options_.odometry);
  if (!odometry) return refuse(odometry.error().message);
  releaseHeld();
  body_T_cam_ = body_T_cam;
  rgbd_.reset();
  calibration_ = *calibration;
  rectifier_ = std::move(rectifier);
  odometry_.emplace(std::move(*odometry));
  hold_.begin(options_.odometry.self_calibrate ? options_.startup_hold_s : 0.0);
  calibration_repeat_ = channels::CalibrationRepeat{};
  calibration_decided_ = false;
  ++stats_.calibrations;
  return Ok{};
}

Status VoPipeline::handleCalibrationBytes(const void* data, int64_t size) {
  auto msg = messages::decodeLcm<evermap::stereo_calib_t>(data, size, "STEREO_CALIB");
  if (!msg) {
    ++stats_.undecodable;
    return msg.error();
  }
  return handleCalibration(*msg);
}

evermap::vo_delta_t toMsg(const FrameResult& r) {
  evermap::vo_delta_t m{};
  m.utime = r.utime;
  m.ref_utime = r.ref_utime;
  m.status = static_cast<int8_t>(r.status);
  m.keyframe_changed = r.keyframe_changed ? 1 : 0;
  messages::putPose(r.ref_T_cur, m.translation, m.orientation);
  for (int i = 0; i < 6; ++i) {
    for (int j = 0; j < 6; ++j) m.covariance[i * 6 + j] = r.covariance(i, j);
  }
  m.num_features = r.num_features;
  m.num_matches = r.num_matches;
  m.num_inliers = r.num_inliers;
  return m;
}

PipelineOutput VoPipeline::finish(const FrameResult& result) {
  PipelineOutput out;
  out.result = result;
  out.delta = toMsg(result);
  if (result.keyframe) out.keyframe = messages::toMsg(odometry_->camera(), *result.keyframe);
  return out;
}

PipelineOutput VoPipeline::publish(PipelineOutput out) {
  odometry_frame_.stamp(out.delta);
  ++stats_.frames;
  ++stats_.by_status[static_cast<size_t>(out.result.status)];
  if (out.keyframe) ++stats_.keyframes;
  out.calibration = calibrationDue(out.result);
  return out;
}

PipelineOutputs VoPipeline::emit(PipelineOutput out, const cv::Mat& left, const cv::Mat& right) {
  PipelineOutputs outs = std::exchange(released_, {});
  if (!hold_.active()) {
    outs.push_back(publish(std::move(out)));
    return outs;
  }
  // The images are the caller's (a decoder's or rectifier's buffers may be reused).
  hold_.keep(StartupHold::Frame{std::move(out), left.clone(), right.clone()});
  if (hold_.due()) endHold(&outs);
  return outs;
}

void VoPipeline::endHold(PipelineOutputs* outs) {
  auto frames = hold_.end();
  // A correction on the last frame held: the frames before it are measured again with it,
  // from a fresh start (self-calibration goes on with its next round).
  const bool again = odometry_ && !frames.empty() && frames.back().corrected();
  if (again) odometry_->reset();
  for (auto& f : frames) {
    const bool decided = f.decided();
    PipelineOutput out = std::move(f.output);
    if (again && !f.left.empty()) {
      const FrameResult first = out.result;
      out = finish(odometry_->process(first.utime, f.left, f.right));
      if (decided) {
        std::string& m = out.result.calibration_message;
        m = first.calibration_message + " (the " + std::to_string(frames.size() - 1) +
            " frames held before it processed again)" + (m.empty() ? "" : "; then " + m);
        out.result.calibration_changed = true;
      }
    }
    outs->push_back(publish(std::move(out)));
  }
}

void VoPipeline::releaseHeld() {
  if (hold_.active()) endHold(&released_);
}

PipelineOutputs VoPipeline::flush() {
  releaseHeld();
  return std::exchange(released_, {});
}

std::optional<evermap::stereo_calib_t> VoPipeline::calibrationDue(const FrameResult& result) {
  if (!calibration_ || !odometry_ || result.status == VoStatus::kBadInput) return std::nullopt;
  const bool now = !result.calibration_message.empty();
  calibration_decided_ = calibration_decided_ || now;
  if (!calibration_decided_) return std::nullopt;
  if (!calibration_repeat_.due(result.utime) && !now) return std::nullopt;
  const core::StereoCalibration rectified =
      rectifier_ ? rectifier_->rectifiedCalibration() : *calibration_;
  auto with_offset = core::withDisparityOffset(rectified, odometry_->camera().disparityOffsetPx());
  if (!with_offset) return std::nullopt;
  return messages::toMsg(*with_offset, result.utime);
}

PipelineOutputs VoPipeline::badInput(int64_t utime, const std::string& why) {
  FrameResult r;
  r.utime = utime;
  r.ref_utime = utime;
  r.status = VoStatus::kBadInput;
  r.message = why;
  return emit(finish(r));
}

PipelineOutputs VoPipeline::handleStereo(const evermap::stereo_image_t& msg) {
  if (!odometry_) return badInput(msg.utime, no_camera_reason_);
  if (!calibration_)
    return badInput(msg.utime,
                    "STEREO: the camera is RGB-D (from RGBD frames), no stereo calibration");
  // Before decoding: a PNG or zstd frame may claim up to kMaxImageSide^2 pixels (268 MB) in a
  // few bytes; only the calibrated camera's size is worth decompressing. fromMsg decodes the
  // right image on a second thread while the left one decodes.
  const core::CameraCalibration& cam = calibration_->left;
  for (const evermap::image_t* im : {&msg.left, &msg.right}) {
    if (im->width != cam.width || im->height != cam.height) {
      return badInput(msg.utime, "STEREO: a " + std::to_string(im->width) + "x" +
                                     std::to_string(im->height) + " image, the calibration is " +
                                     std::to_string(cam.width) + "x" + std::to_string(cam.height));
    }
  }
  return handleFrame(msg.utime, messages::fromMsg(msg));
}

PipelineOutputs VoPipeline::handleFrame(int64_t utime,
                                        const Expected<messages::StereoFrame>& frame) {
  if (!odometry_) return badInput(utime, no_camera_reason_);
  if (!frame) return badInput(utime, "STEREO: " + frame.error().message);
  if (!calibration_)
    return badInput(utime, "STEREO: the camera is RGB-D (from RGBD frames), no stereo calibration");
  if (frame->rectified != calibration_->rectified) {
    return badInput(utime, frame->rectified
                               ? "STEREO: a rectified pair but the calibration is raw"
                               : "STEREO: a raw pair but the calibration is rectified");
  }
  if (rectifier_) {
    auto rect = rectifier_->rectify(frame->left, frame->right);
    if (!rect) return badInput(utime, "STEREO: " + rect.error().message);
    return emit(finish(odometry_->process(utime, rect->left, rect->right)), rect->left,
                rect->right);
  }
  return emit(finish(odometry_->process(utime, frame->left, frame->right)), frame->left,
              frame->right);
}

Expected<PipelineOutputs> VoPipeline::handleStereoBytes(const void* data, int64_t size) {
  auto msg = messages::decodeLcm<evermap::stereo_image_t>(data, size, "STEREO");
  if (!msg) {
    ++stats_.undecodable;
    return msg.error();
  }
  return handleStereo(*msg);
}

PipelineOutputs VoPipeline::handleRgbd(const evermap::rgbd_image_t& msg) {
  return handleRgbdFrame(msg.utime, messages::fromMsg(msg));
}

namespace {

bool sameCamera(const core::CameraCalibration& a, const core::CameraCalibration& b) {
  auto bytes = [](const core::CameraCalibration& c) {
    const evermap::camera_calib_t m = messages::toMsg(c);
    std::vector<uint8_t> out(static_cast<size_t>(m.getEncodedSize()));
    m.encode(out.data(), 0, static_cast<int>(out.size()));
    return out;
  };
  return bytes(a) == bytes(b);
}

}  // namespace

PipelineOutputs VoPipeline::handleRgbdFrame(int64_t utime,
                                            const Expected<messages::RgbdFrame>& frame) {
  if (!frame) return badInput(utime, "RGBD: " + frame.error().message);
  if (!rgbd_ || !odometry_ || !sameCamera(rgbd_->calibration(), frame->camera)) {
    // A new camera (the first frame, or another calibration): odometry restarts with it.
    releaseHeld();
    hold_.begin(0.0);  // no self-calibration
    calibration_.reset();
    rectifier_.reset();
    odometry_.reset();
    rgbd_.reset();
    auto camera = core::RgbdCamera::create(frame->camera, options_.rgbd);
    if (!camera) {
      ++stats_.calibrations_refused;
      no_camera_reason_ = "RGBD calibration refused: " + camera.error().message;
      return badInput(utime, no_camera_reason_);
    }
    OdometryOptions odometry_options = options_.odometry;
    odometry_options.registration.motion.inlier_max_reprojection_px =
        options_.rgbd_inlier_max_reprojection_px;
    odometry_options.registration.motion.max_mean_reprojection_px =
        options_.rgbd_max_mean_reprojection_px;
    odometry_options.fast_motion_fraction = options_.rgbd_fast_motion_fraction;
    odometry_options.self_calibrate = false;  // depth from the depth image: no disparity offset
    auto odometry = StereoOdometry::create(camera->stereo(), odometry_options);
    if (!odometry) {
      ++stats_.calibrations_refused;
      no_camera_reason_ = "RGBD calibration refused: " + odometry.error().message;
      return badInput(utime, no_camera_reason_);
    }
    body_T_cam_ = frame->camera.body_T_cam;
    rgbd_.emplace(std::move(*camera));
    odometry_.emplace(std::move(*odometry));
    ++stats_.calibrations;
  }
  if (Status s = rgbd_->undistort(frame->gray, frame->depth, &rgbd_gray_, &rgbd_depth_); !s) {
    return badInput(utime, "RGBD: " + s.error().message);
  }
  return emit(finish(odometry_->processRgbd(utime, rgbd_gray_, rgbd_depth_, frame->depth_scale_m)));
}

Expected<PipelineOutputs> VoPipeline::handleRgbdBytes(const void* data, int64_t size) {
  auto msg = messages::decodeLcm<evermap::rgbd_image_t>(data, size, "RGBD");
  if (!msg) {
    ++stats_.undecodable;
    return msg.error();
  }
  return handleRgbd(*msg);
}

}  // namespace evermap::vo
