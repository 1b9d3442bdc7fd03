#include "core/registration/frame_registration.h"

#include <cmath>
#include <numbers>
#include <sstream>

#include <Eigen/Geometry>

#include "core/common/option_fields.h"

namespace evermap::core {

const char* toString(RegistrationStatus status) {
  switch (status) {
    case RegistrationStatus::kOk:
      return "ok";
    case RegistrationStatus::kInsufficientFeatures:
      return "insufficient features";
    case RegistrationStatus::kInsufficientInliers:
      return "insufficient inliers";
    case RegistrationStatus::kOptimizationFailure:
      return "optimization failure";
    case RegistrationStatus::kReprojectionError:
      return "reprojection error";
    case RegistrationStatus::kBadInput:
      return "bad input";
  }
  return "?";
}

void RegistrationOptions::declareOptions(OptionList& o) {
  o.nest("matching.", &matching);
  o.nest("clique.", &clique);
  o.add("disparity_sigma_px", &disparity_sigma_px, "px",
        "disparity noise behind the depth uncertainty the clique allows for (0: threshold only)")
      .nonNegative();
  o.nest("motion.", &motion);
  o.add("min_features", &min_features, "features",
        "fewest features with depth (and descriptors) in each frame")
      .min(3);
  o.add("min_inliers", &min_inliers, "inliers",
        "fewest inliers for a registration to be accepted (>= motion.min_inliers)")
      .min(3);
  o.add("ambiguity_ratio", &ambiguity_ratio, "",
        "a second consistent set this fraction of the clique's size refuses the answer (0: off)")
      .nonNegative();
  o.add("ambiguity_translation_m", &ambiguity_translation_m, "m",
        "... when its motion differs by more than this ...")
      .positive();
  o.add("ambiguity_rotation_deg", &ambiguity_rotation_deg, "deg", "... or this").positive();
}

Status RegistrationOptions::validate() const {
  if (Status s = checkOptionRanges(*this, "registration."); !s) return s;
  if (Status s = matching.validate(); !s) return s;
  if (Status s = motion.validate(); !s) return s;
  if (min_inliers < motion.min_inliers) {
    return makeError("registration: min_inliers ", min_inliers, " is below motion.min_inliers ",
                     motion.min_inliers);
  }
  return Ok{};
}

namespace {

// The rigid motion a_T_b of matched 3-D points (least squares, Umeyama without scale).
SE3d rigidFit(const std::vector<Eigen::Vector3d>& pa, const std::vector<Eigen::Vector3d>& pb,
              const std::vector<int>& members) {
  Eigen::Matrix3Xd src(3, static_cast<Eigen::Index>(members.size())), dst(3, src.cols());
  for (size_t k = 0; k < members.size(); ++k) {
    src.col(static_cast<Eigen::Index>(k)) = pb[static_cast<size_t>(members[k])];
    dst.col(static_cast<Eigen::Index>(k)) = pa[static_cast<size_t>(members[k])];
  }
  const Eigen::Matrix4d T = Eigen::umeyama(src, dst, false);
  return SE3d(SO3d::fromMatrix(T.topLeftCorner<3, 3>()), T.topRightCorner<3, 1>());
}

// The points of the matches in their cameras, with their depth noise σ_z = z² σ_d / (fx b)
// (first order of z = fx b / d) when disparity_sigma_px > 0.
struct MatchedPoints {
  std::vector<Eigen::Vector3d> pa, pb;
  std::vector<double> sigma_a, sigma_b;
};

MatchedPoints matchedPoints(const StereoCamera& camera_a, const StereoCamera& camera_b,
                            const std::vector<Correspondence>& matches,
                            const RegistrationOptions& options) {
  MatchedPoints p;
  p.pa.reserve(matches.size());
  p.pb.reserve(matches.size());
  auto depthSigma = [&](const StereoCamera& c, double z) {
    return z * z * options.disparity_sigma_px / (c.fx() * c.baselineM());
  };
  for (const Correspondence& m : matches) {
    p.pa.push_back(m.p_a);
    p.pb.push_back(m.p_b);
    if (options.disparity_sigma_px > 0.0) {
      p.sigma_a.push_back(depthSigma(camera_a, m.p_a.z()));
      p.sigma_b.push_back(depthSigma(camera_b, m.p_b.z()));
    }
  }
  return p;
}

// The motion estimate into the summary: pose, covariance, inliers as index pairs, status and
// message.
void takeMotion(const MotionEstimate& motion, const std::vector<std::pair<int, int>>& ids,
                const RegistrationOptions& options, RegistrationSummary* s) {
  s->a_T_b = motion.a_T_b;
  s->covariance = motion.covariance;
  s->num_inliers = static_cast<int>(motion.inliers.size());
  s->mean_reprojection_px = motion.mean_reprojection_px;
  s->inliers.reserve(motion.inliers.size());
  for (int i : motion.inliers) s->inliers.push_back(ids[static_cast<size_t>(i)]);
  std::ostringstream msg;
  msg << s->num_matches << " matches, " << s->num_clique << " in the clique, " << s->num_inliers
      << " inliers, mean reprojection error " << s->mean_reprojection_px << " px";
  switch (motion.status) {
    case MotionStatus::kOk:
      if (s->num_inliers < options.min_inliers) {
        s->status = RegistrationStatus::kInsufficientInliers;
        msg << " (need " << options.min_inliers << " inliers)";
      } else {
        s->status = RegistrationStatus::kOk;
      }
      break;
    case MotionStatus::kInsufficientInliers:
      s->status = RegistrationStatus::kInsufficientInliers;
      msg << ": " << motion.message;
      break;
    case MotionStatus::kOptimizationFailure:
      s->status = RegistrationStatus::kOptimizationFailure;
      msg << ": " << motion.message;
      break;
    case MotionStatus::kReprojectionError:
      s->status = RegistrationStatus::kReprojectionError;
      msg << ": " << motion.message;
      break;
  }
  s->message = msg.str();
}

}  // namespace

std::optional<std::string> ambiguity(const std::vector<Eigen::Vector3d>& pa,
                                     const std::vector<Eigen::Vector3d>& pb,
                                     const std::vector<double>& sigma_a,
                                     const std::vector<double>& sigma_b,
                                     const std::vector<int>& clique,
                                     const RegistrationOptions& options) {
  std::vector<bool> used(pa.size(), false);
  for (int i : clique) used[static_cast<size_t>(i)] = true;
  std::vector<int> rest;
  for (size_t i = 0; i < pa.size(); ++i)
    if (!used[i]) rest.push_back(static_cast<int>(i));
  const double needed = std::max<double>(
      options.min_inliers, options.ambiguity_ratio * static_cast<double>(clique.size()));
  if (static_cast<double>(rest.size()) < needed) return std::nullopt;
  std::vector<Eigen::Vector3d> ra, rb;
  std::vector<double> rsa, rsb;
  for (int i : rest) {
    const auto k = static_cast<size_t>(i);
    ra.push_back(pa[k]);
    rb.push_back(pb[k]);
    if (!sigma_a.empty()) {
      rsa.push_back(sigma_a[k]);
      rsb.push_back(sigma_b[k]);
    }
  }
  std::vector<int> second = maxConsistentClique(ra, rb, rsa, rsb, options.clique);
  if (static_cast<double>(second.size()) < needed) return std::nullopt;
  const SE3d first_T = rigidFit(pa, pb, clique);
  const SE3d second_T = rigidFit(ra, rb, second);
  const SE3d d = first_T.inverse() * second_T;
  const double dt = d.translation().norm();
  const double dr = rotationAngle(d.so3()) * 180.0 / std::numbers::pi;
  if (dt <= options.ambiguity_translation_m && dr <= options.ambiguity_rotation_deg)
    return std::nullopt;
  std::ostringstream why;
  why << "a second consistent set of " << second.size() << " matches moves " << dt << " m, " << dr
      << " deg differently (repeated structure)";
  return why.str();
}

RegistrationSummary registerMatches(const StereoCamera& camera_a, const StereoCamera& camera_b,
                                    const std::vector<Correspondence>& matches,
                                    const std::vector<std::pair<int, int>>& ids,
                                    const SE3d& initial, const RegistrationOptions& options) {
  RegistrationSummary s;
  s.num_matches = static_cast<int>(matches.size());
  if (ids.size() != matches.size()) {
    s.status = RegistrationStatus::kBadInput;
    s.message =
        makeError("registration: ", matches.size(), " matches but ", ids.size(), " index pairs")
            .message;
    return s;
  }
  const MatchedPoints points = matchedPoints(camera_a, camera_b, matches, options);
  const std::vector<Eigen::Vector3d>& pa = points.pa;
  const std::vector<Eigen::Vector3d>& pb = points.pb;
  const std::vector<double>& sigma_a = points.sigma_a;
  const std::vector<double>& sigma_b = points.sigma_b;
  const std::vector<int> clique = maxConsistentClique(pa, pb, sigma_a, sigma_b, options.clique);
  s.num_clique = static_cast<int>(clique.size());
  if (s.num_clique < options.min_inliers) {
    s.status = RegistrationStatus::kInsufficientInliers;
    s.message = makeError(s.num_matches, " matches, ", s.num_clique, " consistent (clique), need ",
                          options.min_inliers)
                    .message;
    return s;
  }
  if (options.ambiguity_ratio > 0.0) {
    if (auto why = ambiguity(pa, pb, sigma_a, sigma_b, clique, options)) {
      s.status = RegistrationStatus::kInsufficientInliers;
      s.message =
          makeError(s.num_matches, " matches, ", s.num_clique, " in the clique: ambiguous, ", *why)
              .message;
      return s;
    }
  }
  const MotionEstimate motion =
      estimateMotion(camera_a, camera_b, matches, clique, initial, options.motion);
  takeMotion(motion, ids, options, &s);
  return s;
}

RegistrationSummary registerFrames(const StereoCamera& camera_a, const KeyframeFeatures& a,
                                   const StereoCamera& camera_b, const KeyframeFeatures& b,
                                   const RegistrationOptions& options) {
  RegistrationSummary s;
  s.num_features_a = static_cast<int>(a.size());
  s.num_features_b = static_cast<int>(b.size());
  for (const Status& v : {options.validate(), a.validate(), b.validate()}) {
    if (!v) {
      s.status = RegistrationStatus::kBadInput;
      s.message = v.error().message;
      return s;
    }
  }
  if (s.num_features_a < options.min_features || s.num_features_b < options.min_features) {
    s.status = RegistrationStatus::kInsufficientFeatures;
    s.message = makeError("keyframes have ", s.num_features_a, " and ", s.num_features_b,
                          " features, need ", options.min_features)
                    .message;
    return s;
  }
  const std::vector<std::pair<int, int>> ids =
      matchDescriptors(a.descriptors, b.descriptors, options.matching);
  std::vector<Correspondence> matches;
  matches.reserve(ids.size());
  for (const auto& [i, j] : ids) {
    const auto ii = static_cast<size_t>(i), jj = static_cast<size_t>(j);
    matches.push_back({a.keypoints[ii].cast<double>(), a.points[ii].cast<double>(),
                       b.keypoints[jj].cast<double>(), b.points[jj].cast<double>()});
  }
  RegistrationSummary r = registerMatches(camera_a, camera_b, matches, ids, SE3d(), options);
  r.num_features_a = s.num_features_a;
  r.num_features_b = s.num_features_b;
  return r;
}

}  // namespace evermap::core
