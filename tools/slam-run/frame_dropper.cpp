#include "tools/slam-run/frame_dropper.h"

#include <cmath>

namespace evermap::slam_run {

Status FrameDropOptions::validate() const {
  if (!(fraction >= 0.0 && fraction <= 0.5)) {
    return makeError("drop fraction ", fraction, " is outside [0, 0.5]");
  }
  if (!(burst_probability >= 0.0 && burst_probability <= 1.0)) {
    return makeError("drop burst_probability ", burst_probability, " is outside [0, 1]");
  }
  if (burst_frames < 1) return makeError("drop burst_frames ", burst_frames, " must be >= 1");
  return Ok{};
}

FrameDropper::FrameDropper(const FrameDropOptions& options)
    : options_(options), rng_(options.seed) {
  const double f = options.fraction;
  const double mean_length = 1.0 + options.burst_probability * (options.burst_frames - 1);
  // f = L q / (1 - q + L q)  <=>  q = f / (L (1 - f) + f)
  start_probability_ = f > 0.0 ? f / (mean_length * (1.0 - f) + f) : 0.0;
}

bool FrameDropper::drop() {
  ++frames_;
  if (remaining_ == 0 && start_probability_ > 0.0) {
    std::uniform_real_distribution<double> u(0.0, 1.0);
    if (u(rng_) < start_probability_) {
      remaining_ = u(rng_) < options_.burst_probability ? options_.burst_frames : 1;
    }
  }
  if (remaining_ == 0) return false;
  --remaining_;
  ++dropped_;
  return true;
}

}  // namespace evermap::slam_run
