#include "vo-proc/stereo_odometry.h"

#include <sstream>
#include <utility>
#include <vector>

namespace evermap::vo {

using core::SE3d;

const char* toString(VoStatus status) {
  switch (status) {
    case VoStatus::kOk: return "ok";
    case VoStatus::kNoData: return "no data";
    case VoStatus::kInsufficientFeatures: return "insufficient features";
    case VoStatus::kInsufficientInliers: return "insufficient inliers";
    case VoStatus::kOptimizationFailure: return "optimization failure";
    case VoStatus::kReprojectionError: return "reprojection error";
    case VoStatus::kBadInput: return "bad input";
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
  // FOVIS's fixed clique threshold: between consecutive frames the depth-dependent allowance
  // lets in more wrong patch matches than it saves far points (measured: 3x the rotation
  // drift on the synthetic loop).
  o.clique.threshold_m = 0.1;
  o.disparity_sigma_px = 0.0;
  o.motion.inlier_max_reprojection_px = 1.0;
  o.motion.max_mean_reprojection_px = 1.5;
  o.motion.min_inliers = 10;
  o.min_features = 30;
  o.min_inliers = 15;
  o.ambiguity_ratio = 0.0;  // the window search around the prediction does not alias
  return o;
}

Status OdometryOptions::validate() const {
  if (Status s = features.validate(); !s) return s;
  if (Status s = matching.validate(); !s) return s;
  if (Status s = registration.validate(); !s) return s;
  if (Status s = orb.validate(); !s) return s;
  if (keyframe_inlier_threshold < registration.min_inliers) {
    return makeError("odometry: keyframe_inlier_threshold ", keyframe_inlier_threshold,
                     " is below registration.min_inliers ", registration.min_inliers);
  }
  if (!(keyframe_inlier_fraction >= 0.0 && keyframe_inlier_fraction < 1.0)) {
    return makeError("odometry: keyframe_inlier_fraction ", keyframe_inlier_fraction,
                     " is not in [0, 1)");
  }
  if (max_failed_frames < 0) {
    return makeError("odometry: max_failed_frames ", max_failed_frames, " is negative");
  }
  if (!(rotation.max_angle_rad > 0.0) || rotation.max_iterations < 1) {
    return makeError("odometry: rotation estimate needs max_angle_rad > 0 and iterations >= 1");
  }
  return Ok{};
}

std::string OdometryOptions::describe() const {
  std::ostringstream s;
  s << "levels " << features.feature_levels << " (pyramid " << features.pyramid_levels
    << "), FAST " << features.fast.describe() << ", stereo window "
    << 2 * features.stereo.window_radius_px + 1 << " px max disparity "
    << features.stereo.max_disparity_px << " px, search radius " << matching.search_radius_px
    << " px, clique " << registration.clique.threshold_m << " m, inlier error "
    << registration.motion.inlier_max_reprojection_px << " px, min features "
    << registration.min_features << ", min inliers " << registration.min_inliers
    << ", keyframe below " << keyframe_inlier_threshold << " inliers or "
    << keyframe_inlier_fraction << " of the first, rotation estimate "
    << (estimate_rotation ? "on" : "off");
  return s.str();
}

Expected<StereoOdometry> StereoOdometry::create(const core::StereoCamera& camera,
                                                const OdometryOptions& options) {
  if (Status s = options.validate(); !s) return s.error();
  auto extractor = core::StereoFeatureExtractor::create(options.features);
  if (!extractor) return extractor.error();
  return StereoOdometry(camera, options, std::move(*extractor));
}

StereoOdometry::StereoOdometry(const core::StereoCamera& camera, const OdometryOptions& options,
                               core::StereoFeatureExtractor extractor)
    : camera_(camera),
      options_(options),
      extractor_(std::move(extractor)),
      orb_(options.orb),
      ref_(std::make_unique<core::FeatureFrame>()),
      cur_(std::make_unique<core::FeatureFrame>()) {}

StereoOdometry::StereoOdometry(StereoOdometry&&) noexcept = default;
StereoOdometry& StereoOdometry::operator=(StereoOdometry&&) noexcept = default;
StereoOdometry::~StereoOdometry() = default;

int StereoOdometry::fastThreshold() const { return extractor_.detector().threshold(); }

void StereoOdometry::reset() {
  has_ref_ = false;
  prev_top_.release();
  ref_T_prev_ = SE3d();
  failures_ = 0;
  first_inliers_ = 0;
}

void StereoOdometry::makeCurrentTheReference(FrameResult* result) {
  std::swap(ref_, cur_);
  has_ref_ = true;
  ref_T_prev_ = SE3d();
  failures_ = 0;
  first_inliers_ = 0;
  result->keyframe_changed = true;
  if (options_.keyframe_descriptors) {
    result->keyframe = core::makeKeyframeFeatures(*ref_, orb_);
  }
}

FrameResult StereoOdometry::process(int64_t utime, const cv::Mat& left, const cv::Mat& right) {
  FrameResult r;
  r.utime = utime;
  r.ref_utime = has_ref_ ? ref_->utime : utime;
  if (has_ref_ && utime <= ref_->utime) {
    r.status = VoStatus::kBadInput;
    r.message = makeError("frame ", utime, " is not after its reference ", ref_->utime).message;
    return r;
  }
  if (Status s = extractor_.extract(camera_, utime, left, right, cur_.get()); !s) {
    r.status = VoStatus::kBadInput;
    r.message = s.error().message;
    return r;
  }
  r.num_corners = cur_->num_corners;
  r.num_features = static_cast<int>(cur_->features.size());

  // Initial rotation between the previous frame and this one (FOVIS section 3.3).
  std::optional<core::SO3d> cur_R_prev;
  const int top = cur_->left.numLevels() - 1;
  const cv::Mat& top_image = cur_->left.level(top);
  if (options_.estimate_rotation && prev_top_.size() == top_image.size()) {
    cur_R_prev = core::estimateRotation(prev_top_, top_image, camera_, top, options_.rotation);
  }
  top_image.copyTo(prev_top_);
  SE3d ref_T_pred = ref_T_prev_;
  if (cur_R_prev) ref_T_pred = ref_T_prev_ * SE3d(cur_R_prev->inverse(), core::Vec3::Zero());

  if (r.num_features < options_.registration.min_features) {
    r.status = VoStatus::kInsufficientFeatures;
    r.message = makeError(r.num_features, " features with depth (", r.num_corners,
                          " corners at FAST threshold ", fastThreshold(), "), need ",
                          options_.registration.min_features).message;
    if (has_ref_) {
      ++failures_;
      ref_T_prev_ = ref_T_pred;
    }
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
    // The reference is stale: the prediction (the motion before the failures) no longer says
    // where to look, and a window search from a wrong prediction in a repeated texture (floor
    // tiles) finds a wrong motion with many inliers. The chain restarts here, as at a first
    // frame; the mapper bridges the gap.
    r.status = VoStatus::kNoData;
    r.message = makeError("the reference is stale after ", failures_,
                          " failed frames: this frame becomes the reference").message;
    r.ref_utime = utime;
    makeCurrentTheReference(&r);
    return r;
  }

  // Match the reference into this frame and register (a = reference, b = current).
  const std::vector<core::WindowMatch> window =
      core::matchInWindow(camera_, *ref_, *cur_, ref_T_pred.inverse(), options_.matching);
  std::vector<core::Correspondence> matches;
  std::vector<std::pair<int, int>> ids;
  matches.reserve(window.size());
  ids.reserve(window.size());
  for (const core::WindowMatch& m : window) {
    const core::StereoFeature& a = ref_->features[static_cast<size_t>(m.ref)];
    const core::StereoFeature& b = cur_->features[static_cast<size_t>(m.cur)];
    // The refined position keeps the corner's disparity.
    const auto p_b = camera_.backProject(core::Vec3(m.uv.x(), m.uv.y(), b.disparity));
    if (!p_b) continue;
    matches.push_back({a.uv.cast<double>(), a.point, m.uv.cast<double>(), *p_b});
    ids.emplace_back(m.ref, m.cur);
  }
  const core::RegistrationSummary reg =
      core::registerMatches(camera_, camera_, matches, ids, ref_T_pred, options_.registration);
  r.num_matches = reg.num_matches;
  r.num_inliers = reg.num_inliers;
  r.mean_reprojection_px = reg.mean_reprojection_px;
  if (reg.ok()) {
    r.status = VoStatus::kOk;
    r.ref_T_cur = reg.a_T_b;
    r.covariance = reg.covariance;
    failures_ = 0;
    ref_T_prev_ = reg.a_T_b;
    if (first_inliers_ == 0) first_inliers_ = reg.num_inliers;
    if (reg.num_inliers < options_.keyframe_inlier_threshold ||
        reg.num_inliers < options_.keyframe_inlier_fraction * first_inliers_) {
      makeCurrentTheReference(&r);
    }
    return r;
  }
  r.status = static_cast<VoStatus>(static_cast<int8_t>(reg.status));
  r.message = reg.message;
  ++failures_;
  ref_T_prev_ = ref_T_pred;
  if (failures_ > options_.max_failed_frames) {
    // The chain breaks: like a first frame, the new reference is its own reference (the
    // VO_DELTA contract, docs/contracts.md); the motion to it is unknown.
    r.message += "; the reference is replaced by this frame";
    r.ref_utime = utime;
    makeCurrentTheReference(&r);
  }
  return r;
}

}  // namespace evermap::vo
