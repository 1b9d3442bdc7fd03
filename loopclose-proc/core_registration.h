#pragma once
// The frame registration loopclose-proc uses by default: core/registration's registerFrames()
// (descriptor matching with mutual check, maximum-clique inliers, 6-DOF refinement by
// bidirectional reprojection error, covariance; paper section IV-D, docs/vo.md) behind the
// FrameRegistration interface. A loopclose Keyframe holds core's camera + KeyframeFeatures,
// validated once when it arrived (core/messages/keyframe_convert.h); registerFrames' a_T_b
// with a = node, b = query is node_T_query.

#include <string>

#include "core/registration/frame_registration.h"
#include "loopclose-proc/registration.h"

namespace evermap::loopclose {

class CoreRegistration final : public FrameRegistration {
 public:
  // Options must be valid (checked by create()).
  static Expected<CoreRegistration> create(const core::RegistrationOptions& options);

  RegistrationOutcome registerFrames(const Keyframe& target, const Keyframe& query) override;
  std::string describe() const override;

 private:
  explicit CoreRegistration(const core::RegistrationOptions& options) : options_(options) {}
  core::RegistrationOptions options_;
};

}  // namespace evermap::loopclose
