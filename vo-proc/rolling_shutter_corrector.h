#pragma once
// The odometry's rolling-shutter correction (core/camera/rolling_shutter.h): every frame's
// features moved to where the camera at its middle row's instant sees them, with the camera's
// angular velocity from the motion prior (the rotation measured on the top pyramid level over
// the last frame) and the camera's line delay (microseconds per row; 0, a global shutter,
// changes nothing).
//
// Why: a Kinect's color camera reads its rows over some 10-30 ms; at the 60 deg/s of a hand-held
// turn a rigid motion between two frames then leaves centimetres in the translation
// (docs/rgbd.md, "Rolling shutter").
//
// The delay is a calibration. With `gather_evidence`, the registered pairs are also gathered
// as evidence on what is left of it (core/registration/curve_evidence.h over candidate
// delays, pairLineDelayCurve): `evermap-vo-run --calibrate-line-delay` runs the odometry again
// with the estimate until nothing significant is left.

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "core/camera/stereo_camera.h"
#include "core/common/expected.h"
#include "core/features/stereo_features.h"
#include "core/geometry/se3.h"
#include "core/registration/curve_evidence.h"
#include "core/registration/disparity_offset.h"
#include "core/registration/disparity_offset_tracker.h"

namespace evermap::vo {

// Angular velocities (rad/s, the camera's frame) by frame time (utime).
using AngularVelocities = std::map<int64_t, Eigen::Vector3d>;

// The evidence's candidates, around the delay the features are corrected with (us per row).
struct LineDelayEvidenceOptions {
  double grid_min_us = -40.0;
  double grid_max_us = 40.0;
  double grid_step_us = 5.0;
  int max_points_per_pair = 100;
  // A pair is evidence when its own curve pins the delay to 20 us; an estimate needs pairs of
  // 8 reference frames; every pair of a run is kept; outliers beyond 3 MADs and 10 us.
  core::CurveEvidenceOptions evidence{20.0, 8, 1000000, 3.0, 10.0};
  // The pair's motion solved under each candidate (as the disparity offset's online estimate).
  core::DisparityOffsetOptions solve = core::DisparityOffsetTrackerOptions::defaultEstimate();
  // The angular velocity a frame's pairs are judged with, by frame time: a calibration's later
  // runs give the trajectory of the run before, differenced on both sides of each frame. A
  // frame not in it: the velocity it was corrected with, the motion prior's (one-sided and
  // noisy), whose noise draws the estimate towards 0 (errors in the variables: on the TUM
  // excerpt 28 us per row, against 44 us with the trajectory's and 48 us with the motion
  // capture's; docs/results/rgbd.md). The features stay corrected with the prior's velocity,
  // so the delay found is the one that corrects best with it.
  std::shared_ptr<const AngularVelocities> angular_velocity;
};

class RollingShutterCorrector {
 public:
  RollingShutterCorrector() = default;  // a global shutter: changes nothing
  // Refuses a delay that is negative or not finite, and an empty grid.
  static Expected<RollingShutterCorrector> create(double line_delay_us, bool gather_evidence,
                                                  const LineDelayEvidenceOptions& options = {});

  bool wantsPairs() const { return evidence_.has_value(); }

  // Sets frame->omega, the angular velocity of prev_T_cur over dt_us, and corrects its features
  // (a feature the correction would move out of the image stays as measured).
  void correctFrame(const core::StereoCamera& camera, const core::SE3d& prev_T_cur, int64_t dt_us,
                    core::FeatureFrame* frame) const;
  // A position `uv` refined in a frame's image near its feature `f`: where it is once corrected
  // as `f` was (the correction is smooth over the pixels of a refinement).
  Eigen::Vector2f corrected(const core::StereoFeature& f, const Eigen::Vector2f& uv) const;
  // The angular velocity `frame`'s pairs are judged with (LineDelayEvidenceOptions).
  Eigen::Vector3d evidenceOmega(const core::FeatureFrame& frame) const;
  // One registered pair (omega_a, omega_b set) of `group` (its reference frame) as evidence.
  void addPair(const core::StereoCamera& camera, const core::StereoMatchPair& pair, int64_t group);
  // What is left of the delay (us per row), from the pairs so far; nullopt without evidence.
  std::optional<core::CurveEstimate> leftOver() const;

 private:
  double line_delay_us_ = 0.0;
  std::optional<core::CurveEvidence> evidence_;
  std::shared_ptr<const AngularVelocities> evidence_omega_;
  std::vector<double> grid_s_;
  int max_points_per_pair_ = 100;
  core::DisparityOffsetOptions solve_;
};

}  // namespace evermap::vo
