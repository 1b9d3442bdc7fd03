#include "loopclose-proc/core_registration.h"

#include "core/registration/frame_registration.h"

namespace evermap::loopclose {

Expected<CoreRegistration> CoreRegistration::create(const core::RegistrationOptions& options) {
  if (Status s = options.validate(); !s) {
    return makeError("registration options: ", s.error().message);
  }
  return CoreRegistration(options);
}

RegistrationOutcome CoreRegistration::registerFrames(const Keyframe& target,
                                                     const Keyframe& query) {
  RegistrationOutcome o;
  const core::RegistrationSummary s =
      core::registerFrames(target.camera, target.features, query.camera, query.features, options_);
  o.inliers = s.num_inliers;
  if (!s.ok()) {
    o.reason = std::string(core::toString(s.status)) + ": " + s.message;
    return o;
  }
  o.ok = true;
  o.target_T_query = s.a_T_b;
  o.covariance = s.covariance;
  return o;
}

std::string CoreRegistration::describe() const {
  return "core registration (descriptor matching, clique inliers, reprojection refinement), "
         "min " +
         std::to_string(options_.min_inliers) + " inliers";
}

}  // namespace evermap::loopclose
