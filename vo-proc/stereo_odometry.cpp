#include "vo-proc/stereo_odometry.h"

#include <algorithm>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

namespace evermap::vo {

using core::SE3d;

const char* toString(VoStatus status) {
  switch (status) {
    case VoStatus::kOk:
      return "ok";
    case VoStatus::kNoData:
      return "no data";
    case VoStatus::kInsufficientFeatures:
      return "insufficient features";
    case VoStatus::kInsufficientInliers:
      return "insufficient inliers";
    case VoStatus::kOptimizationFailure:
      return "optimization failure";
    case VoStatus::kReprojectionError:
      return "reprojection error";
    case VoStatus::kBadInput:
      return "bad input";
  }
  return "?";
}

core::StereoFeatureExtractor::Options OdometryOptions::defaultFeatures() {
  core::StereoFeatureExtractor::Options o;
  o.feature_levels = 3;
  o.pyramid_levels = 4;
  return o;
}

core::RegistrationOptions OdometryOptions::defaultRegistration() {
  core::RegistrationOptions o;
  // FOVIS's 0.1 m plus the depth noise along the rays of the pair (clique_inliers.h): with
  // the fixed threshold alone, far points (most of an outdoor view: KITTI at ~1 m per frame)
  // never agree with each other, and 26-39 of ~250 matches are consistent instead of ~190.
  // The same noise whitens the motion estimate's residuals (far points under translation).
  o.clique.threshold_m = 0.1;
  o.disparity_sigma_px = 0.2;
  o.motion.disparity_sigma_px = 0.2;
  o.motion.inlier_max_reprojection_px = 1.0;
  o.motion.max_rejection_rounds = 4;
  o.motion.max_mean_reprojection_px = 1.5;
  o.motion.min_inliers = 10;
  o.min_features = 30;
  o.min_inliers = 15;
  o.ambiguity_ratio = 0.0;  // the window search around the prediction does not alias
  return o;
}

Status OdometryOptions::validate() const {
  if (Status s = checkOptionRanges(*this, "odometry."); !s) return s;
  if (Status s = features.validate(); !s) return s;
  if (Status s = matching.validate(); !s) return s;
  if (Status s = registration.validate(); !s) return s;
  if (Status s = orb.validate(); !s) return s;
  if (self_calibrate) {
    if (Status s = self_calibration.validate(); !s) return s;
  }
  if (keyframe_inlier_threshold < registration.min_inliers) {
    return makeError("odometry: keyframe_inlier_threshold ", keyframe_inlier_threshold,
                     " is below registration.min_inliers ", registration.min_inliers);
  }
  return Ok{};
}

std::string OdometryOptions::describe() const {
  std::ostringstream s;
  s << "levels " << features.feature_levels << " (pyramid " << features.pyramid_levels << "), FAST "
    << features.fast.describe() << ", stereo window " << 2 * features.stereo.window_radius_px + 1
    << " px max disparity " << features.stereo.max_disparity_px << " px, search radius "
    << matching.search_radius_px << " px, clique " << registration.clique.threshold_m
    << " m, inlier error " << registration.motion.inlier_max_reprojection_px << " px, min features "
    << registration.min_features << ", min inliers " << registration.min_inliers
    << ", keyframe below " << keyframe_inlier_threshold << " inliers or "
    << keyframe_inlier_fraction << " of the first, keyframe after " << keyframe_min_translation_m
    << " m or " << keyframe_min_rotation_rad << " rad, rotation estimate "
    << (estimate_rotation ? "on" : "off") << ", constant velocity "
    << (constant_velocity ? "on" : "off") << ", retry previous frame "
    << (retry_previous_frame ? "on" : "off") << ", bridge breaks " << (bridge_breaks ? "on" : "off")
    << " (" << bridge.translation_sigma_m << " m, " << bridge.rotation_sigma_rad << " rad + "
    << bridge.velocity_fraction << " of the motion per frame)";
  if (line_delay_us > 0.0) s << ", rolling shutter " << line_delay_us << " us per row";
  return s.str();
}

Expected<StereoOdometry> StereoOdometry::create(const core::StereoCamera& camera,
                                                const OdometryOptions& options) {
  if (Status s = options.validate(); !s) return s.error();
  auto extractor = core::StereoFeatureExtractor::create(options.features);
  if (!extractor) return extractor.error();
  StereoOdometry odometry(camera, options, std::move(*extractor));
  if (options.self_calibrate) {
    auto tracker = core::DisparityOffsetTracker::create(camera, options.self_calibration);
    if (!tracker) return tracker.error();
    odometry.offset_tracker_.emplace(std::move(*tracker));
  }
  LineDelayEvidenceOptions evidence;
  evidence.angular_velocity = options.line_delay_angular_velocity;
  auto rolling_shutter = RollingShutterCorrector::create(
      options.line_delay_us, options.gather_line_delay_evidence, evidence);
  if (!rolling_shutter) return rolling_shutter.error();
  odometry.rolling_shutter_ = std::move(*rolling_shutter);
  return odometry;
}

StereoOdometry::StereoOdometry(const core::StereoCamera& camera, const OdometryOptions& options,
                               core::StereoFeatureExtractor extractor)
    : camera_(camera),
      options_(options),
      extractor_(std::move(extractor)),
      orb_(options.orb),
      ref_(std::make_unique<core::FeatureFrame>()),
      prev_(std::make_unique<core::FeatureFrame>()),
      cur_(std::make_unique<core::FeatureFrame>()) {}

StereoOdometry::StereoOdometry(StereoOdometry&&) noexcept = default;
StereoOdometry& StereoOdometry::operator=(StereoOdometry&&) noexcept = default;
StereoOdometry::~StereoOdometry() = default;

int StereoOdometry::fastThreshold() const { return extractor_.detector().threshold(); }

std::optional<core::DisparityOffsetState> StereoOdometry::selfCalibration() const {
  if (!offset_tracker_) return std::nullopt;
  return offset_tracker_->state();
}

void StereoOdometry::selfCalibrate(const core::StereoMatchPair& pair, int64_t group,
                                   FrameResult* r) {
  if (!offset_tracker_ || !offset_tracker_->wantsPairs() || pair.uvd_a.empty()) return;
  const core::DisparityOffsetState& state = offset_tracker_->add(pair, group);
  if (state.decision == core::OffsetDecision::kPending) return;
  r->calibration_message = state.message;
  if (state.decision == core::OffsetDecision::kApply) {
    applyDisparityCorrection(state.offset_px, state.row_slope);
    r->calibration_changed = true;
    r->disparity_offset_px = camera_.disparityOffsetPx();
    r->disparity_row_slope = camera_.disparityRowSlope();
  }
  // After an offset applied, the next round measures what is left over; once a round finds
  // nothing to change, self-calibration is over: rounds run on forever would each be a new
  // chance of a false alarm on a right rig.
  if (state.decision != core::OffsetDecision::kKeep) offset_tracker_->restart(camera_);
}

void StereoOdometry::applyDisparityCorrection(double delta_px, double delta_slope) {
  auto camera = core::StereoCamera::create(camera_.fx(), camera_.fy(), camera_.cx(), camera_.cy(),
                                           camera_.baselineM(), camera_.width(), camera_.height(),
                                           camera_.disparityOffsetPx() + delta_px,
                                           camera_.disparityRowSlope() + delta_slope);
  if (!camera) return;  // beyond the camera's bounds (a quarter of the width): not applied
  camera_ = *camera;
  // The frames kept (reference, last registered, current) measured their depths with the old
  // correction: their disparities and points move with it; a feature left without depth goes.
  for (core::FeatureFrame* frame : {ref_.get(), prev_.get(), cur_.get()}) {
    std::vector<core::StereoFeature>& features = frame->features;
    for (core::StereoFeature& f : features) {
      f.disparity += static_cast<float>(delta_px + delta_slope * (f.uv.y() - camera_.cy()));
      const auto p = camera_.backProject(core::Vec3(f.uv.x(), f.uv.y(), f.disparity));
      if (p) f.point = *p;
    }
    std::erase_if(features, [](const core::StereoFeature& f) { return !(f.disparity > 0.0f); });
  }
}

void StereoOdometry::reset() {
  // The detector's adaptive threshold too (the options were valid when this was made).
  if (auto extractor = core::StereoFeatureExtractor::create(options_.features))
    extractor_ = std::move(*extractor);
  has_ref_ = false;
  has_prev_ = false;
  prev_top_.release();
  ref_T_prev_ = SE3d();
  ref_T_good_ = SE3d();
  ref_T_good_cov_.setZero();
  frames_since_good_ = 0;
  prev_T_cur_motion_ = SE3d();
  has_motion_ = false;
  prev_utime_ = -1;
  frame_dt_us_ = motion_dt_us_ = 0;
  kf_T_ref_ = core::UncertainPose{};
  failures_ = 0;
  first_inliers_ = 0;
}

bool StereoOdometry::farEnoughForAKeyframe(const SE3d& kf_T_cur) const {
  return kf_T_cur.translation().norm() >= options_.keyframe_min_translation_m ||
         core::rotationAngle(kf_T_cur.so3()) >= options_.keyframe_min_rotation_rad;
}

void StereoOdometry::makeCurrentTheReference(FrameResult* result, bool keyframe,
                                             const core::UncertainPose& kf_T_cur) {
  std::swap(ref_, cur_);
  has_ref_ = true;
  has_prev_ = false;
  ref_T_prev_ = SE3d();
  ref_T_good_ = SE3d();
  ref_T_good_cov_.setZero();
  frames_since_good_ = 0;
  failures_ = 0;
  first_inliers_ = 0;
  if (!keyframe) {
    kf_T_ref_ = kf_T_cur;
    return;
  }
  kf_utime_ = ref_->utime;
  kf_T_ref_ = core::UncertainPose{};
  result->keyframe_changed = true;
  if (options_.keyframe_descriptors) {
    result->keyframe = core::makeKeyframeFeatures(*ref_, orb_);
  }
}

std::optional<core::RegistrationOptions> fastMotionRegistration(
    const core::RegistrationOptions& registration, double fx, const SE3d& prev_T_pred,
    double fraction) {
  const double image_motion_px = fx * core::rotationAngle(prev_T_pred.so3());
  const double bound_px = fraction * image_motion_px;
  core::RegistrationOptions widened = registration;
  core::MotionOptions& motion = widened.motion;
  if (!(bound_px > motion.inlier_max_reprojection_px)) return std::nullopt;
  motion.max_mean_reprojection_px *= bound_px / motion.inlier_max_reprojection_px;
  motion.inlier_max_reprojection_px = bound_px;
  return widened;
}

core::RegistrationSummary StereoOdometry::registerTo(
    const core::FeatureFrame& from, const SE3d& from_T_pred, core::StereoMatchPair* pair,
    const core::RegistrationOptions* registration) const {
  const std::vector<core::WindowMatch> window =
      core::matchInWindow(camera_, from, *cur_, from_T_pred.inverse(), options_.matching);
  std::vector<core::Correspondence> matches;
  std::vector<std::pair<int, int>> ids;
  matches.reserve(window.size());
  ids.reserve(window.size());
  for (const core::WindowMatch& m : window) {
    const core::StereoFeature& a = from.features[static_cast<size_t>(m.ref)];
    const core::StereoFeature& b = cur_->features[static_cast<size_t>(m.cur)];
    // The refined position keeps the corner's disparity (and its rolling-shutter correction).
    const Eigen::Vector2f uv_b = rolling_shutter_.corrected(b, m.uv);
    const auto p_b = camera_.backProject(core::Vec3(uv_b.x(), uv_b.y(), b.disparity));
    if (!p_b) continue;
    matches.push_back({a.uv.cast<double>(), a.point, uv_b.cast<double>(), *p_b});
    ids.emplace_back(m.ref, m.cur);
  }
  core::RegistrationSummary summary =
      core::registerMatches(camera_, camera_, matches, ids, from_T_pred,
                            registration != nullptr ? *registration : options_.registration);
  if (pair != nullptr && summary.ok()) {
    // Every match, not only the inliers: the inliers were chosen under the camera's offset, and
    // a wrong offset is what pushes the points it distorts most out of them (the estimate
    // leans to the current offset); the offset's robust cost bounds the outliers' weight.
    pair->a_T_b = summary.a_T_b;
    pair->omega_a = rolling_shutter_.evidenceOmega(from);
    pair->omega_b = rolling_shutter_.evidenceOmega(*cur_);
    for (size_t k = 0; k < matches.size(); ++k) {
      const core::StereoFeature& a = from.features[static_cast<size_t>(ids[k].first)];
      const core::StereoFeature& b = cur_->features[static_cast<size_t>(ids[k].second)];
      pair->uvd_a.emplace_back(a.uv.x(), a.uv.y(), a.disparity);
      pair->uvd_b.emplace_back(matches[k].uv_b.x(), matches[k].uv_b.y(), b.disparity);
    }
  }
  return summary;
}

core::Mat6 StereoOdometry::priorCovariance(const SE3d& prev_T_cur, int frames) const {
  const auto& b = options_.bridge;
  const double st = b.translation_sigma_m + b.velocity_fraction * prev_T_cur.translation().norm();
  const double sr =
      b.rotation_sigma_rad + b.velocity_fraction * core::rotationAngle(prev_T_cur.so3());
  core::Mat6 c = core::Mat6::Zero();
  c.diagonal() << st * st, st * st, st * st, sr * sr, sr * sr, sr * sr;
  return static_cast<double>(std::max(frames, 1)) * c;
}

void StereoOdometry::bridge(const SE3d& ref_T_pred, FrameResult* r) {
  // ref_T_pred = ref_T_good · good_T_pred: the last registered frame, then the prediction
  // over the frames since; the prior's variance grows with their number.
  const SE3d good_T_pred = ref_T_good_.inverse() * ref_T_pred;
  const SE3d per_frame = has_motion_ ? prev_T_cur_motion_ : SE3d();
  const core::UncertainPose bridged =
      core::compound({ref_T_good_, ref_T_good_cov_},
                     {good_T_pred, priorCovariance(per_frame, frames_since_good_)});
  const core::UncertainPose kf_T_cur = core::compound(kf_T_ref_, bridged);
  r->status = VoStatus::kOk;
  r->bridged = true;
  r->ref_T_cur = kf_T_cur.mean;
  r->covariance = kf_T_cur.covariance;
  r->message = makeError("bridged by the motion prior over ", frames_since_good_, " frames (",
                         r->failure_kind, ": ", r->message, ")")
                   .message;
  makeCurrentTheReference(r);
}

namespace {

const char* failureKind(const core::RegistrationSummary& reg, int min_inliers) {
  switch (reg.status) {
    case core::RegistrationStatus::kInsufficientInliers:
      return reg.num_clique < min_inliers ? "too few consistent matches"
                                          : "too few inliers after outlier rejection";
    case core::RegistrationStatus::kReprojectionError:
      return "reprojection error";
    case core::RegistrationStatus::kOptimizationFailure:
      return "optimization failure";
    case core::RegistrationStatus::kInsufficientFeatures:
      return "too few features";
    case core::RegistrationStatus::kBadInput:
      return "bad input";
    case core::RegistrationStatus::kOk:
      return "";
  }
  return "?";
}

}  // namespace

FrameResult StereoOdometry::process(int64_t utime, const cv::Mat& left, const cv::Mat& right) {
  return track(
      utime, [&] { return extractor_.extract(camera_, utime, left, right, cur_.get()); }, nullptr);
}

FrameResult StereoOdometry::processRgbd(int64_t utime, const cv::Mat& gray, const cv::Mat& depth,
                                        double depth_scale_m) {
  return track(
      utime,
      [&] {
        return extractor_.extractRgbd(camera_, utime, gray, depth, depth_scale_m, cur_.get());
      },
      &depth);
}

FrameResult StereoOdometry::track(int64_t utime, const std::function<Status()>& extract,
                                  const cv::Mat* depth) {
  FrameResult r;
  r.utime = utime;
  r.ref_utime = has_ref_ ? kf_utime_ : utime;
  r.disparity_offset_px = camera_.disparityOffsetPx();
  r.disparity_row_slope = camera_.disparityRowSlope();
  if (!extractFrame(utime, extract, &r)) return r;
  const SE3d ref_T_pred = predictMotion(utime);
  rolling_shutter_.correctFrame(camera_, ref_T_prev_.inverse() * ref_T_pred, frame_dt_us_,
                                cur_.get());
  if (has_ref_) ++frames_since_good_;

  if (r.num_features < options_.registration.min_features) {
    failTooFewFeatures(depth, ref_T_pred, &r);
    return r;
  }
  if (!has_ref_) {
    r.status = VoStatus::kNoData;
    r.message = "first frame: it becomes the reference";
    r.ref_utime = utime;
    makeCurrentTheReference(&r);
    return r;
  }
  if (failures_ > options_.max_failed_frames) {
    restartStaleReference(ref_T_pred, &r);
    return r;
  }
  const RegisteredMotion motion = registerCurrent(ref_T_pred, &r);
  r.num_matches = motion.summary.num_matches;
  r.num_inliers = motion.summary.num_inliers;
  r.mean_reprojection_px = motion.summary.mean_reprojection_px;
  if (motion.summary.ok()) {
    takeMotion(motion, &r);
    selfCalibrate(motion.pair, motion.pair_group, &r);
    rolling_shutter_.addPair(camera_, motion.pair, motion.pair_group);
  } else {
    failRegistration(motion.summary, ref_T_pred, &r);
  }
  return r;
}

bool StereoOdometry::extractFrame(int64_t utime, const std::function<Status()>& extract,
                                  FrameResult* r) {
  if (has_ref_ && utime <= ref_->utime) {
    r->status = VoStatus::kBadInput;
    r->failure_kind = "bad input";
    r->message = makeError("frame ", utime, " is not after its reference ", ref_->utime).message;
    return false;
  }
  if (Status s = extract(); !s) {
    r->status = VoStatus::kBadInput;
    r->failure_kind = "bad input";
    r->message = s.error().message;
    return false;
  }
  r->num_corners = cur_->num_corners;
  r->num_features = static_cast<int>(cur_->features.size());
  return true;
}

SE3d StereoOdometry::predictMotion(int64_t utime) {
  frame_dt_us_ = prev_utime_ >= 0 ? utime - prev_utime_ : 0;
  prev_utime_ = utime;
  // The motion prior: the last frame-to-frame motion at the same velocity, with the measured
  // rotation (FOVIS section 3.3) between the previous frame and this one, searched from the
  // prior's.
  SE3d prev_T_pred =
      options_.constant_velocity && has_motion_ ? scaledMotion(frame_dt_us_) : SE3d();
  std::optional<core::SO3d> cur_R_prev;
  const int top = cur_->left.numLevels() - 1;
  const cv::Mat& top_image = cur_->left.level(top);
  if (options_.estimate_rotation && prev_top_.size() == top_image.size()) {
    cur_R_prev = core::estimateRotation(prev_top_, top_image, camera_, top, options_.rotation,
                                        prev_T_pred.so3().inverse());
  }
  top_image.copyTo(prev_top_);
  if (cur_R_prev) prev_T_pred = SE3d(cur_R_prev->inverse(), prev_T_pred.translation());
  return ref_T_prev_ * prev_T_pred;
}

SE3d StereoOdometry::scaledMotion(int64_t dt_us) const {
  // A frame lost in between (vo-proc's queue under load, a camera's dropped frame) makes the
  // interval longer than the last motion's: the same velocity moves farther. Equal intervals
  // (the usual case) leave the motion exactly as measured.
  if (dt_us <= 0 || motion_dt_us_ <= 0 || dt_us == motion_dt_us_) return prev_T_cur_motion_;
  const double ratio = std::min(static_cast<double>(dt_us) / static_cast<double>(motion_dt_us_),
                                kMaxVelocityExtrapolation);
  return SE3d(core::SO3d::exp(ratio * prev_T_cur_motion_.so3().log()),
              ratio * prev_T_cur_motion_.translation());
}

void StereoOdometry::failTooFewFeatures(const cv::Mat* depth, const SE3d& ref_T_pred,
                                        FrameResult* r) {
  r->status = VoStatus::kInsufficientFeatures;
  r->failure_kind = "too few features";
  r->message = makeError(r->num_features, " features with depth (", r->num_corners,
                         " corners at FAST threshold ", fastThreshold(), "), need ",
                         options_.registration.min_features)
                   .message;
  if (depth != nullptr && !depth->empty() && cv::countNonZero(*depth) == 0) {
    r->message += ": the depth image is all zero (no pixel has a depth)";
  }
  if (has_ref_) {
    ++failures_;
    ref_T_prev_ = ref_T_pred;
  }
}

void StereoOdometry::restartStaleReference(const SE3d& ref_T_pred, FrameResult* r) {
  // The reference is stale: the prediction (the motion before the failures) no longer says
  // where to look, and a window search from a wrong prediction in a repeated texture (floor
  // tiles) finds a wrong motion with many inliers. The chain restarts here, bridged by the
  // motion prior or, without one, as at a first frame (the mapper bridges the gap).
  r->failure_kind = "stale reference";
  r->message = makeError("the reference is stale after ", failures_, " failed frames").message;
  if (options_.bridge_breaks && has_motion_) {
    bridge(ref_T_pred, r);
    return;
  }
  r->status = VoStatus::kNoData;
  r->message += ": this frame becomes the reference";
  r->ref_utime = r->utime;
  makeCurrentTheReference(r);
}

StereoOdometry::RegisteredMotion StereoOdometry::registerCurrent(const SE3d& ref_T_pred,
                                                                 FrameResult* r) const {
  // Register to the reference (a = reference, b = current); failing that, to the last frame
  // that registered, the motion through it chained to the reference.
  RegisteredMotion m;
  const bool calibrating =
      (offset_tracker_ && offset_tracker_->wantsPairs()) || rolling_shutter_.wantsPairs();
  m.takeRegistration(registerTo(*ref_, ref_T_pred, calibrating ? &m.pair : nullptr));
  m.pair_group = ref_->utime;
  if (!m.summary.ok() && options_.retry_previous_frame && has_prev_) {
    const RegisteredMotion again = registerThroughPrevious(ref_T_pred, nullptr);
    if (again.summary.ok()) {
      r->via_previous = true;
      r->message = "registered to the previous frame " + std::to_string(prev_->utime) +
                   " after failing against the reference (" +
                   failureKind(m.summary, options_.registration.min_inliers) + ": " +
                   m.summary.message + ")";
      m.takeMotionOf(again);
    }
  }
  if (!m.summary.ok() && options_.fast_motion_fraction > 0.0) retryFastMotion(ref_T_pred, &m, r);
  return m;
}

void StereoOdometry::retryFastMotion(const SE3d& ref_T_pred, RegisteredMotion* m,
                                     FrameResult* r) const {
  // The prediction over the last frame: the rotation measured on the top pyramid level.
  const std::optional<core::RegistrationOptions> widened =
      fastMotionRegistration(options_.registration, camera_.fx(),
                             ref_T_prev_.inverse() * ref_T_pred, options_.fast_motion_fraction);
  if (!widened) return;
  const std::string failure =
      std::string(failureKind(m->summary, options_.registration.min_inliers)) + ": " +
      m->summary.message;
  RegisteredMotion again;
  again.takeRegistration(registerTo(*ref_, ref_T_pred, nullptr, &*widened));
  if (!again.summary.ok() && has_prev_) {
    again = registerThroughPrevious(ref_T_pred, &*widened);
    r->via_previous = again.summary.ok();
  }
  if (!again.summary.ok()) return;
  r->fast_motion = true;
  r->message = makeError("registered with the inlier bound widened to ",
                         widened->motion.inlier_max_reprojection_px,
                         " px for fast motion after failing (", failure, ")")
                   .message;
  m->takeMotionOf(again);
}

StereoOdometry::RegisteredMotion StereoOdometry::registerThroughPrevious(
    const SE3d& ref_T_pred, const core::RegistrationOptions* registration) const {
  RegisteredMotion m;
  m.summary = registerTo(*prev_, ref_T_good_.inverse() * ref_T_pred, nullptr, registration);
  if (!m.summary.ok()) return m;
  const core::UncertainPose chained =
      core::compound({ref_T_good_, ref_T_good_cov_}, {m.summary.a_T_b, m.summary.covariance});
  m.ref_T_cur = chained.mean;
  m.covariance = chained.covariance;
  return m;
}

void StereoOdometry::takeMotion(const RegisteredMotion& m, FrameResult* r) {
  const core::UncertainPose kf_T_cur = core::compound(kf_T_ref_, {m.ref_T_cur, m.covariance});
  r->status = VoStatus::kOk;
  r->ref_T_cur = kf_T_cur.mean;
  r->covariance = kf_T_cur.covariance;
  failures_ = 0;
  prev_T_cur_motion_ = ref_T_prev_.inverse() * m.ref_T_cur;
  motion_dt_us_ = frame_dt_us_;
  has_motion_ = true;
  ref_T_prev_ = m.ref_T_cur;
  const int inliers = m.summary.num_inliers;
  if (first_inliers_ == 0) first_inliers_ = inliers;
  if (r->via_previous || r->fast_motion || inliers < options_.keyframe_inlier_threshold ||
      inliers < options_.keyframe_inlier_fraction * first_inliers_) {
    makeCurrentTheReference(r, farEnoughForAKeyframe(kf_T_cur.mean), kf_T_cur);
  } else {
    std::swap(prev_, cur_);
    has_prev_ = true;
    ref_T_good_ = m.ref_T_cur;
    ref_T_good_cov_ = m.covariance;
    frames_since_good_ = 0;
  }
}

void StereoOdometry::failRegistration(const core::RegistrationSummary& reg, const SE3d& ref_T_pred,
                                      FrameResult* r) {
  r->status = static_cast<VoStatus>(static_cast<int8_t>(reg.status));
  r->failure_kind = failureKind(reg, options_.registration.min_inliers);
  r->message = reg.message;
  ++failures_;
  ref_T_prev_ = ref_T_pred;
  if (failures_ > options_.max_failed_frames) {
    if (options_.bridge_breaks && has_motion_) {
      bridge(ref_T_pred, r);
      return;
    }
    // The chain breaks: like a first frame, the new reference is its own reference (the
    // VO_DELTA contract, docs/contracts.md); the motion to it is unknown.
    r->message += "; the reference is replaced by this frame";
    r->ref_utime = r->utime;
    makeCurrentTheReference(r);
  }
}

}  // namespace evermap::vo
