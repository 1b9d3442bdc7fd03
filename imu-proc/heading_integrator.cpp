#include "imu-proc/heading_integrator.h"

#include <cmath>

#include "core/common/contract.h"

namespace evermap::imu {

Status HeadingOptions::validate() const { return checkOptionRanges(*this, "heading."); }

HeadingIntegrator::HeadingIntegrator(const HeadingOptions& options) : o_(options) {
  requireValid(o_.validate(), "HeadingIntegrator");
  bias_var_ = o_.initial_bias_sigma_rad_s * o_.initial_bias_sigma_rad_s;
}

double HeadingIntegrator::rateSigmaRadS() const { return std::sqrt(bias_var_); }

void HeadingIntegrator::add(const ImuSample& s, const core::SO3d& world_R_body) {
  up_body_ = world_R_body.inverse() * Eigen::Vector3d::UnitZ();
  if (!started_ || s.utime <= utime_) {
    if (!started_) {
      started_ = true;
      utime_ = s.utime;
      epoch_ = s.utime;
      rate_ = up_body_.dot(s.gyro_rad_s - bias_);
    }
    stillness(s);
    return;
  }
  const double dt = static_cast<double>(s.utime - utime_) * 1e-6;
  utime_ = s.utime;
  bias_var_ += o_.bias_walk_density * o_.bias_walk_density * dt;
  const double rate = up_body_.dot(s.gyro_rad_s - bias_);
  if (dt > o_.max_gap_s) {
    // The rotation during the gap is unknown: not integrated (the consumer sees the gap in
    // the message times and does not bridge it with the gyro).
    ++counts_.gaps;
    window_.clear();
    epoch_ = s.utime;
  } else {
    heading_ += 0.5 * (rate_ + rate) * dt;
  }
  rate_ = rate;
  stillness(s);
}

void HeadingIntegrator::stillness(const ImuSample& s) {
  window_.push_back(s);
  const auto window_us = static_cast<int64_t>(o_.still_window_s * 1e6);
  if (window_.back().utime - window_.front().utime < window_us) return;
  Eigen::Vector3d mean_w = Eigen::Vector3d::Zero(), mean_f = Eigen::Vector3d::Zero();
  for (const ImuSample& x : window_) {
    mean_w += x.gyro_rad_s;
    mean_f += x.accel_m_s2;
  }
  const double n = static_cast<double>(window_.size());
  mean_w /= n;
  mean_f /= n;
  bool still =
      (mean_w - bias_).norm() <= o_.still_max_rate_rad_s + 3.0 * std::sqrt(3.0 * bias_var_);
  for (const ImuSample& x : window_) {
    if (!still) break;
    still = (x.gyro_rad_s - mean_w).cwiseAbs().maxCoeff() <= o_.still_gyro_spread_rad_s &&
            (x.accel_m_s2 - mean_f).cwiseAbs().maxCoeff() <= o_.still_accel_spread_m_s2;
  }
  if (!still) {
    window_.pop_front();  // slide
    return;
  }
  // Zero-rate update: the window's mean gyro reading measures the bias, per axis, with the
  // white noise averaged over the window.
  const double span_s = static_cast<double>(window_.back().utime - window_.front().utime) * 1e-6;
  const double r = o_.noise_density * o_.noise_density / span_s;
  const double k = bias_var_ / (bias_var_ + r);
  bias_ += k * (mean_w - bias_);
  bias_var_ = (1.0 - k) * bias_var_;
  rate_ = up_body_.dot(s.gyro_rad_s - bias_);
  ++counts_.still_updates;
  window_.clear();  // the next measurement uses new samples: independent noise
}

}  // namespace evermap::imu
