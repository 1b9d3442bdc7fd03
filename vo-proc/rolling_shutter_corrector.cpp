#include "vo-proc/rolling_shutter_corrector.h"

#include <cmath>
#include <utility>

#include "core/camera/rolling_shutter.h"

namespace evermap::vo {

Expected<RollingShutterCorrector> RollingShutterCorrector::create(
    double line_delay_us, bool gather_evidence, const LineDelayEvidenceOptions& options) {
  if (!(std::isfinite(line_delay_us) && line_delay_us >= 0.0)) {
    return makeError("rolling shutter: line delay ", line_delay_us,
                     " us is negative or not finite");
  }
  RollingShutterCorrector c;
  c.line_delay_us_ = line_delay_us;
  if (gather_evidence) {
    if (!(options.grid_step_us > 0.0 && options.grid_min_us < options.grid_max_us)) {
      return makeError("rolling shutter: the line delay's grid [", options.grid_min_us, ", ",
                       options.grid_max_us, "] us by ", options.grid_step_us, " is empty");
    }
    std::vector<double> grid_us =
        core::evenGrid(options.grid_min_us, options.grid_max_us, options.grid_step_us);
    for (double us : grid_us) c.grid_s_.push_back(us * 1e-6);
    c.evidence_.emplace(std::move(grid_us), options.evidence);
    c.max_points_per_pair_ = options.max_points_per_pair;
    c.solve_ = options.solve;
    c.evidence_omega_ = options.angular_velocity;
  }
  return c;
}

void RollingShutterCorrector::correctFrame(const core::StereoCamera& camera,
                                           const core::SE3d& prev_T_cur, int64_t dt_us,
                                           core::FeatureFrame* frame) const {
  frame->omega = dt_us > 0 ? Eigen::Vector3d(prev_T_cur.so3().log() / (1e-6 * double(dt_us)))
                           : Eigen::Vector3d::Zero();
  if (line_delay_us_ == 0.0) return;
  for (core::StereoFeature& f : frame->features) {
    const Eigen::Vector3d uvd(f.uv.x(), f.uv.y(), f.disparity);
    const auto moved = core::toMiddleRow(camera, uvd, frame->omega, line_delay_us_ * 1e-6);
    // A point the turn would put behind the camera or out of the image: left as measured.
    if (!moved || !camera.inImage(moved->x(), moved->y())) continue;
    const auto p = camera.backProject(*moved);
    if (!p) continue;
    f.uv = moved->head<2>().cast<float>();
    f.disparity = static_cast<float>(moved->z());
    f.point = *p;
  }
}

Eigen::Vector2f RollingShutterCorrector::corrected(const core::StereoFeature& f,
                                                   const Eigen::Vector2f& uv) const {
  if (line_delay_us_ == 0.0) return uv;
  return f.uv + (uv - f.cornerUv());
}

Eigen::Vector3d RollingShutterCorrector::evidenceOmega(const core::FeatureFrame& frame) const {
  if (evidence_omega_) {
    const auto it = evidence_omega_->find(frame.utime);
    if (it != evidence_omega_->end()) return it->second;
  }
  return frame.omega;
}

void RollingShutterCorrector::addPair(const core::StereoCamera& camera,
                                      const core::StereoMatchPair& pair, int64_t group) {
  if (!evidence_ || pair.uvd_a.empty() || pair.uvd_a.size() != pair.uvd_b.size()) return;
  evidence_->add(core::pairLineDelayCurve(camera, core::subsampledPair(pair, max_points_per_pair_),
                                          grid_s_, solve_),
                 group);
}

std::optional<core::CurveEstimate> RollingShutterCorrector::leftOver() const {
  if (!evidence_) return std::nullopt;
  return evidence_->estimate();
}

}  // namespace evermap::vo
