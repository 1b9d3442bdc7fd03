#pragma once
// Registration of two stereo frames: the relative pose a_T_b (points of frame b into frame a)
// with its covariance, from features with 3-D points (DESIGN.md section 5; Huang et al. 2011
// sections 3.4-3.6):
//   matches -> inliers by maximum clique of rigidly consistent pairs (clique_inliers.h)
//           -> motion by bidirectional reprojection error (motion_estimation.h)
//           -> accepted when at least min_inliers remain.
// registerFrames() matches two keyframes by their ORB descriptors (brute force, mutual check):
// what loop closure calls. registerMatches() is the shared tail for callers that matched
// otherwise (visual odometry matches patches in a predicted window).

#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/camera/stereo_camera.h"
#include "core/common/expected.h"
#include "core/geometry/se3.h"
#include "core/registration/clique_inliers.h"
#include "core/registration/descriptor_matcher.h"
#include "core/registration/keyframe_features.h"
#include "core/registration/motion_estimation.h"

namespace evermap {
class OptionList;  // core/common/option_fields.h
}  // namespace evermap

namespace evermap::core {

// The values equal vo_delta_t::STATUS_* (lcmtypes/evermap_vo_delta_t.lcm).
enum class RegistrationStatus : int8_t {
  kOk = 0,
  kInsufficientFeatures = 2,  // too few features with depth in a frame: dark, blank wall
  kInsufficientInliers = 3,   // too few consistent matches: occlusion, fast motion, elsewhere
  kOptimizationFailure = 4,
  kReprojectionError = 5,
  kBadInput = 6,  // invalid features or options
};
const char* toString(RegistrationStatus status);

struct RegistrationOptions {
  DescriptorMatchOptions matching;
  CliqueOptions clique;
  // Disparity noise (pixels) behind the depth uncertainty the clique allows for
  // (clique_inliers.h); 0: the fixed threshold only.
  double disparity_sigma_px = 0.2;
  MotionOptions motion;
  // Fewest features with depth (and descriptors, for registerFrames) in each frame.
  int min_features = 20;
  // Fewest inliers for the registration to be accepted (the acceptance threshold).
  int min_inliers = 20;
  // Repeated structure (floor tiles, identical doors): when the matches outside the clique
  // hold a second consistent set of at least this fraction of the clique's size (and
  // min_inliers) whose rigid motion differs by more than ambiguity_translation_m or
  // ambiguity_rotation_deg, the scene registers two ways and the answer is refused as
  // ambiguous. 0 disables (visual odometry, whose window search is not fooled that way).
  double ambiguity_ratio = 0.5;
  double ambiguity_translation_m = 0.3;
  double ambiguity_rotation_deg = 5.0;

  Status validate() const;
  void declareOptions(OptionList& o);
};

struct RegistrationSummary {
  RegistrationStatus status = RegistrationStatus::kBadInput;
  std::string message;  // one line: what was found, or why it failed
  SE3d a_T_b;
  Mat6 covariance = Mat6::Zero();  // right tangent (υ, ω) at a_T_b
  int num_features_a = 0;
  int num_features_b = 0;
  int num_matches = 0;  // putative matches
  int num_clique = 0;   // consistent by the clique
  int num_inliers = 0;  // used by the final motion
  double mean_reprojection_px = 0.0;
  std::vector<std::pair<int, int>> inliers;  // (index in a, index in b)

  bool ok() const { return status == RegistrationStatus::kOk; }
};

// Why the matches register two ways (RegistrationOptions::ambiguity_ratio): a second clique
// among the matches outside `clique`, as large as the ratio asks, whose rigid motion differs
// from the clique's; nothing when there is none. Points and sigmas as maxConsistentClique.
std::optional<std::string> ambiguity(const std::vector<Eigen::Vector3d>& points_a,
                                     const std::vector<Eigen::Vector3d>& points_b,
                                     const std::vector<double>& depth_sigma_a_m,
                                     const std::vector<double>& depth_sigma_b_m,
                                     const std::vector<int>& clique,
                                     const RegistrationOptions& options);

// Registers keyframe b against keyframe a: a_T_b. The cameras are the rectified rigs the
// keyframes were taken with (normally the same).
RegistrationSummary registerFrames(const StereoCamera& camera_a, const KeyframeFeatures& a,
                                   const StereoCamera& camera_b, const KeyframeFeatures& b,
                                   const RegistrationOptions& options);

// The tail of registerFrames() for matches found otherwise: `ids[k]` = (index in a, index in
// b) of matches[k]. `initial` seeds the motion when options.motion.use_initial_guess.
// num_features_* and num_matches of the summary are set from the arguments. `options` must be
// valid (the caller validates them once: visual odometry calls this on every frame).
RegistrationSummary registerMatches(const StereoCamera& camera_a, const StereoCamera& camera_b,
                                    const std::vector<Correspondence>& matches,
                                    const std::vector<std::pair<int, int>>& ids,
                                    const SE3d& initial, const RegistrationOptions& options);

}  // namespace evermap::core
