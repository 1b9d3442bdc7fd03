#pragma once
// The frame registration loopclose-proc calls: the pluggable part. The real one — brute-force
// Hamming matching with mutual check, maximum-clique inliers, 6-DOF refinement by bidirectional
// reprojection error, covariance (paper section IV-D) — lives in core/registration; the
// adapter CoreRegistration (core_registration.h) implements this interface with it and is
// main.cpp's default. Tests may use their own implementations.

#include <string>

#include "core/geometry/se3.h"
#include "loopclose-proc/keyframe.h"

namespace evermap::loopclose {

struct RegistrationOutcome {
  bool ok = false;
  core::SE3d target_T_query;                       // camera frames: p_target = T * p_query
  core::Mat6 covariance = core::Mat6::Identity();  // right tangent, (υ, ω) order
  int inliers = 0;
  std::string reason;  // why not, when !ok
};

class FrameRegistration {
 public:
  virtual ~FrameRegistration() = default;
  // Registers `query` against `target`. Must not throw; bad or insufficient data is an outcome
  // with ok = false and a reason. Called from loopclose-proc's one thread.
  virtual RegistrationOutcome registerFrames(const Keyframe& target, const Keyframe& query) = 0;
  // One line for logs ("vo clique registration, min 30 inliers").
  virtual std::string describe() const = 0;
};

}  // namespace evermap::loopclose

namespace evermap::loopclose {

// Registration switched off: every registration fails with a reason that says so (appearance
// search, node bookkeeping, the map store and the request protocol still work).
class NoRegistration final : public FrameRegistration {
 public:
  RegistrationOutcome registerFrames(const Keyframe&, const Keyframe&) override {
    RegistrationOutcome o;
    o.reason = "frame registration is switched off (NoRegistration)";
    return o;
  }
  std::string describe() const override { return "none (every registration fails)"; }
};

}  // namespace evermap::loopclose
