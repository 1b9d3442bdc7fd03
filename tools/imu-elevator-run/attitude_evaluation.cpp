#include "tools/imu-elevator-run/attitude_evaluation.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>

#include <Eigen/SVD>
#include <utility>

#include "core/messages/convert.h"

namespace evermap::imu {

namespace {
double wrap(double a) { return std::remainder(a, 2.0 * std::numbers::pi); }
}  // namespace

std::string AttitudeErrorSummary::summary() const {
  const double d = 180.0 / std::numbers::pi;
  char buf[300];
  std::snprintf(
      buf, sizeof buf,
      "%d matched; tilt RMS %.3f deg; roll RMS %.3f deg (max %.2f), pitch RMS %.3f deg (max %.2f); "
      "%.1f %% inside 3 sigma; world tilt %.2f deg, body offset %.2f deg",
      matched, tilt_rms_rad * d, roll_rms_rad * d, roll_max_rad * d, pitch_rms_rad * d,
      pitch_max_rad * d, 100.0 * within_3_sigma, world_tilt_rad * d, body_offset_rad * d);
  return buf;
}

Eigen::Vector3d meanSpecificForce(const std::vector<ImuSample>& imu, int64_t t0_utime,
                                  double window_s) {
  const int64_t t1_utime = t0_utime + static_cast<int64_t>(window_s * 1e6);
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  int n = 0;
  for (const ImuSample& s : imu) {
    if (s.utime < t0_utime || s.utime >= t1_utime || !s.accel_m_s2.allFinite()) continue;
    sum += s.accel_m_s2;
    ++n;
  }
  return n > 0 ? Eigen::Vector3d(sum / n) : Eigen::Vector3d::Zero();
}

double referenceTiltAtRest(const std::vector<ImuSample>& imu,
                           const std::vector<datasets::StampedPose>& ground_truth, int64_t t0_utime,
                           double window_s) {
  const int64_t t1_utime = t0_utime + static_cast<int64_t>(window_s * 1e6);
  if (ground_truth.empty() || messages::utimeFromNs(ground_truth.front().t_ns) > t0_utime ||
      messages::utimeFromNs(ground_truth.back().t_ns) < t1_utime) {
    return -1.0;
  }
  const Eigen::Vector3d f = meanSpecificForce(imu, t0_utime, window_s);
  if (f.squaredNorm() == 0) return -1.0;
  const int64_t mid = t0_utime + (t1_utime - t0_utime) / 2;
  const auto it = std::lower_bound(
      ground_truth.begin(), ground_truth.end(), mid,
      [](const datasets::StampedPose& p, int64_t t) { return messages::utimeFromNs(p.t_ns) < t; });
  const Eigen::Vector3d up_world = it->world_T_body.so3() * f.normalized();
  return std::acos(std::clamp(up_world.z(), -1.0, 1.0));
}

namespace {

using TruthPairs = std::vector<std::pair<const Attitude*, core::SO3d>>;

// Ground truth interpolated (slerp) at each estimate's time after skip_s, between two poses at
// most max_offset_s apart in time on each side.
TruthPairs pairWithTruth(const std::vector<Attitude>& estimates,
                         const std::vector<datasets::StampedPose>& ground_truth,
                         const AttitudeCompareOptions& options) {
  const int64_t max_offset_ns = static_cast<int64_t>(options.max_offset_s * 1e9);
  const int64_t t_start_us = estimates.front().utime + static_cast<int64_t>(options.skip_s * 1e6);
  TruthPairs pairs;
  for (const Attitude& e : estimates) {
    if (e.utime < t_start_us) continue;
    const int64_t t_ns = e.utime * 1000;
    auto it =
        std::lower_bound(ground_truth.begin(), ground_truth.end(), t_ns,
                         [](const datasets::StampedPose& p, int64_t t) { return p.t_ns < t; });
    if (it == ground_truth.end() || it == ground_truth.begin()) continue;
    const datasets::StampedPose& p1 = *it;
    const datasets::StampedPose& p0 = *(it - 1);
    if (p1.t_ns - t_ns > max_offset_ns || t_ns - p0.t_ns > max_offset_ns) continue;
    const double f = static_cast<double>(t_ns - p0.t_ns) / static_cast<double>(p1.t_ns - p0.t_ns);
    const core::SO3d R0 = p0.world_T_body.so3();
    const core::SO3d R1 = p1.world_T_body.so3();
    pairs.emplace_back(&e, R0 * core::SO3d::exp(f * (R0.inverse() * R1).log()));
  }
  return pairs;
}

// The world's up and the body mis-calibration gt_R_imu that best explain the estimates:
// alternating least squares, the world up given the body offset a normalised mean, the body
// offset given the world up Wahba's problem (Kabsch, by SVD).
void alignGravity(const TruthPairs& pairs, bool align_body, Eigen::Vector3d* up_world,
                  Eigen::Matrix3d* gt_R_imu) {
  const int rounds = align_body ? 10 : 1;
  for (int round = 0; round < rounds; ++round) {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (const auto& [e, R] : pairs) {
      sum += R * (*gt_R_imu * upFromRollPitch(e->roll_rad, e->pitch_rad));
    }
    *up_world = sum.normalized();
    if (!align_body) break;
    Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
    for (const auto& [e, R] : pairs) {
      H += upFromRollPitch(e->roll_rad, e->pitch_rad) * (R.inverse() * *up_world).transpose();
    }
    const Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
    D(2, 2) = (svd.matrixV() * svd.matrixU().transpose()).determinant() < 0 ? -1 : 1;
    *gt_R_imu = svd.matrixV() * D * svd.matrixU().transpose();
  }
}

}  // namespace

AttitudeErrorSummary compareAttitude(const std::vector<Attitude>& estimates,
                                     const std::vector<datasets::StampedPose>& ground_truth,
                                     const AttitudeCompareOptions& options) {
  AttitudeErrorSummary s;
  if (estimates.empty() || ground_truth.empty()) return s;
  const TruthPairs pairs = pairWithTruth(estimates, ground_truth, options);
  Eigen::Vector3d up_world = Eigen::Vector3d::UnitZ();
  Eigen::Matrix3d gt_R_imu = Eigen::Matrix3d::Identity();  // the body mis-calibration
  const auto refUp = [&](const core::SO3d& world_R_gt) {
    return Eigen::Vector3d(gt_R_imu.transpose() * (world_R_gt.inverse() * up_world));
  };
  if (options.align_gravity && !pairs.empty()) {
    alignGravity(pairs, options.align_body, &up_world, &gt_R_imu);
    s.world_tilt_rad = std::acos(std::clamp(up_world.z(), -1.0, 1.0));
    s.body_offset_rad = core::SO3d::fromMatrix(gt_R_imu).log().norm();
  }
  // The level frame: level_R_imu takes the mean reference up (IMU frame) to +z.
  Eigen::Matrix3d level_R_imu = Eigen::Matrix3d::Identity();
  if (options.vehicle_up_imu.squaredNorm() > 0) {
    level_R_imu = Eigen::Quaterniond::FromTwoVectors(options.vehicle_up_imu.normalized(),
                                                     Eigen::Vector3d::UnitZ())
                      .toRotationMatrix();
  } else if (options.level_body && !pairs.empty()) {
    Eigen::Vector3d mean_up = Eigen::Vector3d::Zero();
    for (const auto& pr : pairs) mean_up += refUp(pr.second);
    level_R_imu = Eigen::Quaterniond::FromTwoVectors(mean_up.normalized(), Eigen::Vector3d::UnitZ())
                      .toRotationMatrix();
  }
  double roll_sq = 0, pitch_sq = 0, tilt_sq = 0;
  int inside = 0;
  for (const auto& [e, R] : pairs) {
    const Eigen::Vector3d up_ref = refUp(R);
    const Eigen::Vector3d up_est = upFromRollPitch(e->roll_rad, e->pitch_rad);
    const Eigen::Vector2d rp_ref = rollPitchFromUp(level_R_imu * up_ref);
    const Eigen::Vector2d rp_est = rollPitchFromUp(level_R_imu * up_est);
    const double er = wrap(rp_est[0] - rp_ref[0]);
    const double ep = wrap(rp_est[1] - rp_ref[1]);
    const double tilt = std::acos(std::clamp(up_ref.dot(up_est), -1.0, 1.0));
    roll_sq += er * er;
    pitch_sq += ep * ep;
    tilt_sq += tilt * tilt;
    s.roll_max_rad = std::max(s.roll_max_rad, std::abs(er));
    s.pitch_max_rad = std::max(s.pitch_max_rad, std::abs(ep));
    // The 3-sigma test on the estimate's own (IMU-frame) roll and pitch.
    const Eigen::Vector2d rp_ref_imu = rollPitchFromUp(up_ref);
    if (std::abs(wrap(e->roll_rad - rp_ref_imu[0])) <= 3.0 * std::sqrt(e->covariance(0, 0)) &&
        std::abs(wrap(e->pitch_rad - rp_ref_imu[1])) <= 3.0 * std::sqrt(e->covariance(1, 1))) {
      ++inside;
    }
    ++s.matched;
  }
  if (s.matched > 0) {
    s.roll_rms_rad = std::sqrt(roll_sq / s.matched);
    s.pitch_rms_rad = std::sqrt(pitch_sq / s.matched);
    s.within_3_sigma = static_cast<double>(inside) / s.matched;
    s.tilt_rms_rad = std::sqrt(tilt_sq / s.matched);
  }
  return s;
}

}  // namespace evermap::imu
