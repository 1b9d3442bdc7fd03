#include "mapper-proc/tracker.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <sstream>
#include <string>

#include <Eigen/Eigenvalues>

#include "core/geometry/se2.h"
#include "core/messages/pose_fields.h"

namespace evermap::mapper {
namespace {

// ATTITUDE messages this far apart (seconds) are a gap: imu-proc restarted, or messages lost.
constexpr double kHeadingGapS = 0.5;

}  // namespace

Status TrackerOptions::validate() const {
  if (Status s = checkOptionRanges(*this, "tracker."); !s) return s;
  if (!(heading_wait_s < vo_timeout_s))
    return Error("tracker.heading_wait_s: must be below tracker.vo_timeout_s");
  return Ok{};
}

std::string Tracker::implausibleMotion(double distance_m, double angle_rad, int64_t from_utime,
                                       int64_t to_utime) const {
  const double span_s = std::max(1e-3, 1e-6 * static_cast<double>(to_utime - from_utime));
  std::ostringstream why;
  if (distance_m > o_.max_speed_m_s * span_s) {
    why << distance_m << " m in " << span_s << " s is faster than tracker.max_speed_m_s "
        << o_.max_speed_m_s;
  } else if (angle_rad > o_.max_turn_rad_s * span_s) {
    why << angle_rad << " rad in " << span_s << " s turns faster than tracker.max_turn_rad_s "
        << o_.max_turn_rad_s;
  }
  return why.str();
}

// The (x, y, yaw) block of a covariance on the right tangent (υ, ω): the motion in the plane.
static Eigen::Matrix3d planarBlock(const Mat6& c) {
  const int idx[3] = {0, 1, 5};
  Eigen::Matrix3d b;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) b(i, j) = c(idx[i], idx[j]);
  return b;
}

// Whether two estimates of one motion agree in the plane (x, y, yaw of the right tangent):
// χ²(3) of their difference under the sum of their covariances.
static bool agreesInPlane(const UncertainPose& a, const UncertainPose& b, double gate) {
  const core::Vec6 d = (a.mean.inverse() * b.mean).log();
  const Eigen::Vector3d r(d[0], d[1], d[5]);
  const Eigen::Matrix3d c =
      planarBlock(a.covariance) + planarBlock(b.covariance) + Eigen::Matrix3d::Identity() * 1e-12;
  return r.dot(c.ldlt().solve(r)) <= gate;
}

Tracker::Tracker(const TrackerOptions& options)
    : o_(options), ad_body_T_cam_(options.body_T_cam.adjoint()) {}

void Tracker::setBodyTCamera(const SE3d& body_T_cam) {
  o_.body_T_cam = body_T_cam;
  ad_body_T_cam_ = body_T_cam.adjoint();
}

UncertainPose Tracker::registrationToBody(const SE3d& cam_T, const Mat6& cam_covariance) const {
  // X' = A X A⁻¹ and X exp(δ) ↦ X' exp(Ad(A) δ) with A = body_T_cam.
  UncertainPose p;
  p.mean = o_.body_T_cam * cam_T * o_.body_T_cam.inverse();
  p.covariance = ad_body_T_cam_ * cam_covariance * ad_body_T_cam_.transpose();
  return p;
}

UncertainPose Tracker::toBody(const SE3d& cam_motion, const Mat6& cam_covariance) const {
  // As registrationToBody, the product symmetrised as it is formed (storing it first and
  // symmetrising after rounds differently, and moves the oracle's year run).
  UncertainPose p;
  p.mean = o_.body_T_cam * cam_motion * o_.body_T_cam.inverse();
  p.covariance = symmetric(ad_body_T_cam_ * cam_covariance * ad_body_T_cam_.transpose());
  return p;
}

void Tracker::commit(int64_t utime, const UncertainPose& increment) {
  base_ = core::compound(base_, increment);  // eq. (6)-(7)
  path_odometer_m_ += increment.mean.translation().norm();
  history_.push_back(Increment{utime, increment});
  const int64_t window = static_cast<int64_t>(o_.history_s * 1e6);
  while (!history_.empty() && history_.front().utime < utime - window) history_.pop_front();
}

Expected<Tracker::VoMotion> Tracker::checkedMotion(const vo_delta_t& msg) {
  if (msg.ref_utime >= msg.utime)
    return Error("VO_DELTA " + std::to_string(msg.utime) + ": reference " +
                 std::to_string(msg.ref_utime) + " is not before the frame");
  const std::string what = "VO_DELTA " + std::to_string(msg.utime);
  const Expected<SE3d> ref_T_cur =
      messages::poseFromMessage(msg.translation, msg.orientation, what.c_str());
  if (!ref_T_cur) return ref_T_cur.error();
  const Eigen::Quaterniond q = ref_T_cur->quaternion();  // normalised
  const Expected<Mat6> cov = messages::covarianceFromMessage(msg.covariance, "VO_DELTA");
  if (!cov) return makeError("VO_DELTA ", msg.utime, ": ", cov.error().message);
  const core::Vec3 t(msg.translation[0], msg.translation[1], msg.translation[2]);
  const std::string implausible =
      implausibleMotion(t.norm(), Eigen::AngleAxisd(q).angle(), msg.ref_utime, msg.utime);
  if (!implausible.empty()) {
    ++counts_.implausible;
    return makeError("VO_DELTA ", msg.utime, ": ", implausible);
  }
  return VoMotion{toBody(SE3d(q, t), *cov), *cov};
}

void Tracker::restartChain(const vo_delta_t& msg, bool ok) {
  // A new reference keyframe at the current estimate.
  if (vo_mode_) {
    commit(msg.utime, pending_);
  } else {
    // VO's first frame after a silence may be older than the wheels' last increments
    // (vo-proc holds its first seconds: vo_pipeline.h): VO's frames will cover those, so they
    // are taken back. Wheel odometry last reached the body at its last message, up to a
    // wheel period before this frame: the rest of the way is extrapolated (in a turn in place
    // a tenth of a second is degrees), its yaw from the gyro.
    takeBackWheelsAfter(msg.utime);
    extrapolateWheel(msg.utime);
    commit(msg.utime, UncertainPose{});
  }
  pending_ = UncertainPose{};
  vo_mode_ = true;
  ref_utime_ = msg.utime;
  recent_wheel_.clear();
  ++counts_.restarts;
  delta_utime_ = msg.utime;
  if (ok)
    ++counts_.vo_applied;
  else
    ++counts_.vo_failed;
  anchorOdometry(msg, Mat6::Zero());
}

Status Tracker::addVo(const vo_delta_t& msg) {
  // Time moved on past a held step: it is taken with the headings there are.
  takeHeldStep();
  if (msg.utime <= last_vo_utime_) {
    ++counts_.dropped;
    return Error("VO_DELTA " + std::to_string(msg.utime) + ": out of order");
  }
  const bool ok = msg.status == vo_delta_t::STATUS_OK;
  // A new reference without a motion to it: VO's first frame, or a chain break.
  const bool restart = msg.keyframe_changed && (!ok || msg.ref_utime == msg.utime);
  // A frame's pose and covariance are checked before anything, its time stamp included, is
  // taken from it: a malformed message leaves the tracker as it was.
  Expected<VoMotion> motion = VoMotion{};
  if (ok && !restart) motion = checkedMotion(msg);
  if (!motion) {
    ++counts_.dropped;
    return motion.error();
  }
  const int64_t previous_vo_utime = last_vo_utime_;
  last_vo_utime_ = msg.utime;
  last_utime_ = std::max(last_utime_, msg.utime);
  if (restart) {
    restartChain(msg, ok);
    return Ok{};
  }
  if (!ok) {
    ++counts_.vo_failed;
    // The last good frame becomes the commit point wheel odometry continues from.
    if (vo_mode_) loseVo(previous_vo_utime);
    odometry_at_delta_.reset();
    return Ok{};
  }
  const UncertainPose& ref_T_body = motion->ref_T_body;
  if (!vo_mode_ || msg.ref_utime != ref_utime_) {
    rejoin(msg.ref_utime, ref_T_body, msg.utime, odometrySinceLastFrame(msg));
  }
  pending_ = ref_T_body;
  delta_utime_ = msg.utime;
  ++counts_.vo_applied;
  anchorOdometry(msg, msg.keyframe_changed ? Mat6::Zero() : motion->covariance);
  if (!msg.keyframe_changed) return Ok{};
  // The gyro's heading that reaches the frame may still be on its way: the step waits for it
  // (its motion is in Δ already).
  const bool headings_flow = !headings_.empty() && headings_.back().utime >= msg.utime - 1'000'000;
  if (o_.heading_wait_s > 0.0 && o_.gyro_heading && headings_flow && !headingReaches(msg.utime)) {
    held_ = HeldStep{msg.ref_utime, msg.utime};
    ++counts_.heading_waits;
    return Ok{};
  }
  takeStep(msg.ref_utime, msg.utime);
  return Ok{};
}

bool Tracker::heldStepDue(int64_t utime) const {
  return held_ && (heldStepCovered() ||
                   utime > held_->utime + static_cast<int64_t>(o_.heading_wait_s * 1e6));
}

bool Tracker::headingReaches(int64_t utime) const {
  return !headings_.empty() && headings_.back().utime >= utime;
}

bool Tracker::heldStepCovered() const { return held_ && headingReaches(held_->utime); }

std::optional<int64_t> Tracker::takeHeldStep() {
  if (!held_) return std::nullopt;
  const HeldStep h = *held_;
  held_.reset();
  // Expired: no heading reached the frame, or the headings broke (addHeading) and no longer
  // reach back to the step's reference.
  if (!gyroYaw(h.ref_utime, h.utime) || !headingReaches(h.utime)) ++counts_.heading_waits_expired;
  takeStep(h.ref_utime, h.utime);
  return h.utime;
}

void Tracker::takeStep(int64_t ref_utime, int64_t utime) {
  if (!testStep(ref_utime, utime, true)) return;
  commit(utime, pending_);
  pending_ = UncertainPose{};
  ref_utime_ = utime;
}

bool Tracker::testStep(int64_t ref_utime, int64_t utime, bool with_wheels) {
  if (ref_utime == reanchored_ref_utime_) return testReanchoredStep(ref_utime, utime);
  if (gyroContradicts(ref_utime, utime, pending_) && wheelsCover(ref_utime, utime)) {
    // VO's step contradicts the gyro: the wheels carry Δ from the step's reference; VO's next
    // frame (on this frame as its reference) is placed where they put the body.
    handToWheels(UncertainPose{}, ref_utime);
    return false;
  }
  if (with_wheels) pending_ = withWheelTranslation(ref_utime, utime, pending_);
  pending_ = withGyroYaw(ref_utime, utime, pending_);
  return true;
}

bool Tracker::testReanchoredStep(int64_t ref_utime, int64_t utime) {
  // Δ spans [reanchored_at_utime_, utime] of this step (the reference sits behind the frame
  // that placed it, by VO's motion to that frame): neither the gyro nor the wheels measure
  // that, so nothing is fused. But VO's own motion over [ref_utime, utime] is what the gyro
  // measures: a VO failure VO did not report that lasts beyond one step (a passer-by filling
  // the view for a second) is caught here too, and the wheels carry Δ from where it had the
  // body when the reference was placed, as from a step's reference after a contradiction.
  if (!gyroContradicts(ref_utime, utime, pending_) || !wheelsCover(reanchored_at_utime_, utime))
    return true;
  handToWheels(reanchored_ref_T_body_, reanchored_at_utime_);
  return false;
}

void Tracker::handToWheels(const UncertainPose& kept, int64_t from_utime) {
  ++counts_.vo_contradicted;
  pending_ = kept;
  enterWheelMode(from_utime);
  odometry_at_delta_.reset();
}

std::optional<std::pair<double, double>> Tracker::gyroInnovation(
    int64_t t0, int64_t t1, const UncertainPose& increment) const {
  const auto gyro = o_.gyro_heading ? gyroYaw(t0, t1) : std::nullopt;
  if (!gyro) return std::nullopt;
  const double s = increment.covariance(5, 5) + gyro->second;
  if (!(s > 0.0)) return std::nullopt;
  return std::make_pair(
      std::remainder(gyro->first - core::toPlanar(increment.mean).theta(), 2.0 * std::numbers::pi),
      s);
}

bool Tracker::gyroContradicts(int64_t t0, int64_t t1, const UncertainPose& increment) const {
  if (!(o_.vo_gyro_gate > 0.0)) return false;
  const auto v = gyroInnovation(t0, t1, increment);
  return v && v->first * v->first > o_.vo_gyro_gate * v->second;
}

UncertainPose Tracker::withGyroYaw(int64_t t0, int64_t t1, const UncertainPose& increment) {
  const auto v = gyroInnovation(t0, t1, increment);
  if (!v) return increment;
  // An EKF update on the right tangent (υ, ω) of the increment: the gyro measures its yaw,
  // H = ∂yaw/∂ξ = e_ωz (the body is level to the IMU's accuracy).
  const auto [innovation, s] = *v;
  const core::Vec6 k = increment.covariance.col(5) / s;
  UncertainPose out;
  out.mean = increment.mean * SE3d::exp(k * innovation);
  out.covariance = symmetric(increment.covariance - k * increment.covariance.row(5));
  ++counts_.gyro_turns;
  return out;
}

void Tracker::loseVo(int64_t last_good_utime) {
  // VO's motion from its reference to its last good frame is a keyframe step cut short: the
  // gyro tests it, and its yaw is fused in. Not the wheels' translation: VO's covariance over
  // its failing frames is not one to spread a disagreement by (rendered seed 7: VO's 13 cm
  // sideways error became 10 cm of height and 2.7° of tilt).
  if (last_good_utime > ref_utime_ && !testStep(ref_utime_, last_good_utime, false)) return;
  enterWheelMode(last_good_utime);
}

void Tracker::enterWheelMode(int64_t lost_utime) {
  commit(std::max(lost_utime, history_.empty() ? lost_utime : history_.back().utime), pending_);
  pending_ = UncertainPose{};
  vo_mode_ = false;
  vo_lost_utime_ = lost_utime;
  odometry_at_vo_lost_.reset();
  delta_utime_ = lost_utime;
  std::deque<wheel_odom_t> buffered;
  buffered.swap(recent_wheel_);
  for (const wheel_odom_t& w : buffered)
    if (w.utime > lost_utime) applyWheel(w, lost_utime);
}

void Tracker::rejoin(int64_t ref_utime, const UncertainPose& ref_T_body, int64_t utime,
                     const std::optional<UncertainPose>& since_last) {
  if (vo_mode_) {
    // VO moved on to a reference whose keyframe change never arrived: commit what is known,
    // up to this frame when the odometry frame spans the messages lost (without it, the
    // motion since the last frame taken is lost: in a turn, degrees per lost keyframe change).
    commit(utime, since_last ? core::compound(pending_, *since_last) : pending_);
    if (since_last) ++counts_.odometry_bridged;
    pending_ = UncertainPose{};
  } else {
    // Wheel odometry reached the body at its last message, up to a wheel period before this
    // frame: brought to the frame's time, so that the two are compared (and the frame placed)
    // over the same interval. In a turn a wheel period is degrees.
    extrapolateWheel(utime);
  }
  // Where Δ has the body: at this frame, or at a wheel increment already applied past it (VO's
  // message came later than the wheels'). The wheels take over from there (testReanchoredStep).
  int64_t placed_at = !vo_mode_ && last_wheel_ ? std::max(utime, last_wheel_->utime) : utime;
  // Back on the reference VO kept through its failures (relinked), or back after a silence
  // with odometry poses that span it (bridged): VO's motion replaces the wheels'.
  if (!vo_mode_ && ref_utime == ref_utime_ && replaceWheels(ref_utime, ref_T_body)) {
    ++counts_.relinked;
    return;
  }
  if (!vo_mode_ && ref_utime != ref_utime_ && since_last &&
      replaceWheels(vo_lost_utime_, *since_last)) {
    // The frame is at the end of VO's motion since its last frame taken (the gyro's yaw over
    // it fused in, as into a keyframe step); its reference is placed behind it, as below.
    commit(utime, withGyroYaw(vo_lost_utime_, utime, *since_last));
    ++counts_.odometry_bridged;
    placed_at = utime;  // the wheels' increments after vo_lost_utime_ were taken back
  }
  // An unknown reference: the frame goes where the estimate (wheel odometry) has the body, so
  // the reference sits at Δ ⊕ (ref_T_body)⁻¹; the increment to it is committed so that the
  // motion since an earlier keyframe still compounds to Δ.
  commit(utime, UncertainPose{ref_T_body.mean.inverse(), Mat6::Zero()});
  vo_mode_ = true;
  ref_utime_ = ref_utime;
  reanchored_ref_utime_ = ref_utime;
  reanchored_at_utime_ = placed_at;
  reanchored_ref_T_body_ = ref_T_body;
  // The wheels' last increment stays kept when it reaches that point (within two of its
  // periods): from there they carry Δ when the gyro contradicts the step from the reference
  // (testReanchoredStep), also before their next increment arrives (a step 50 ms long); only
  // its share after the point counts.
  recent_wheel_.clear();
  if (last_wheel_received_ && reaches(*last_wheel_received_, placed_at))
    recent_wheel_.push_back(*last_wheel_received_);
  ++counts_.reanchored;
}

void Tracker::takeBackWheelsAfter(int64_t utime) {
  // Only the wheels' own increments, those after VO was lost (the commit at vo_lost_utime_
  // and everything before it are VO's); the covariance keeps them: conservative.
  const int64_t from = std::max(utime, vo_lost_utime_);
  while (!history_.empty() && history_.back().utime > from) {
    base_.mean = base_.mean * history_.back().pose.mean.inverse();
    history_.pop_back();
    ++counts_.wheels_taken_back;
  }
}

bool Tracker::replaceWheels(int64_t from_utime, const UncertainPose& vo) {
  // The commit point at from_utime; the increments after it are wheel odometry's.
  auto at = history_.end();
  for (auto h = history_.begin(); h != history_.end(); ++h)
    if (h->utime == from_utime) at = h;
  if (at == history_.end()) return false;
  UncertainPose wheel;  // what wheel odometry says of the same motion
  for (auto h = std::next(at); h != history_.end(); ++h) wheel = core::compound(wheel, h->pose);
  if (!agreesInPlane(wheel, vo, o_.relink_gate)) {
    // VO's motion over the gap contradicts the wheels: a wrong registration (a repeated
    // texture); the frame goes where the wheels put it instead.
    ++counts_.relinks_refused;
    return false;
  }
  if (std::next(at) != history_.end() &&
      planarBlock(vo.covariance).determinant() > planarBlock(wheel.covariance).determinant()) {
    // VO's motion over the gap is less certain than the wheels' (and the gyro's): VO
    // predicted it (a break bridged by its motion prior, contracts.md), it did not measure
    // it. The wheels keep the gap; the frame goes where they put it.
    ++counts_.relinks_weaker;
    return false;
  }
  // The wheel increments are taken back; the covariance keeps them: conservative.
  SE3d undo;
  for (auto h = std::next(at); h != history_.end(); ++h) undo = undo * h->pose.mean;
  base_.mean = base_.mean * undo.inverse();
  history_.erase(std::next(at), history_.end());
  vo_mode_ = true;
  recent_wheel_.clear();
  return true;
}

Status Tracker::addHeading(const attitude_t& msg) {
  if (!msg.heading_valid || !o_.gyro_heading) return Ok{};
  if (!std::isfinite(msg.heading_rad) || !std::isfinite(msg.heading_rate_sigma_rad_s) ||
      msg.heading_rate_sigma_rad_s < 0.0) {
    ++counts_.dropped;
    return makeError("ATTITUDE ", msg.utime, ": heading not finite");
  }
  if (!headings_.empty() && msg.utime <= headings_.back().utime) {
    ++counts_.dropped;
    return makeError("ATTITUDE ", msg.utime, ": heading out of order");
  }
  // A gap (imu-proc restarted, messages lost) or a jump no body turns by: the headings
  // before it belong to another integration, and nothing bridges the gap; unless both sides
  // say they are one integration (heading_epoch): then only messages were lost.
  if (!headings_.empty()) {
    const HeadingSample& last = headings_.back();
    const double dt = static_cast<double>(msg.utime - last.utime) * 1e-6;
    const bool one_integration = msg.heading_epoch != 0 && msg.heading_epoch == last.epoch;
    if ((dt > kHeadingGapS && !one_integration) ||
        std::abs(msg.heading_rad - last.heading_rad) > 10.0 * dt + 0.1)
      headings_.clear();
  }
  headings_.push_back(
      HeadingSample{msg.utime, msg.heading_rad, msg.heading_rate_sigma_rad_s, msg.heading_epoch});
  const auto keep = static_cast<int64_t>((o_.wheel_buffer_s + 5.0) * 1e6);
  while (headings_.front().utime < msg.utime - keep) headings_.pop_front();
  return Ok{};
}

std::optional<std::pair<double, double>> Tracker::gyroYaw(int64_t t0, int64_t t1) const {
  if (headings_.size() < 2 || t0 < headings_.front().utime) return std::nullopt;
  const auto extrapolation = static_cast<int64_t>(o_.heading_extrapolation_s * 1e6);
  if (t1 > headings_.back().utime + extrapolation) return std::nullopt;
  const auto gap = static_cast<int64_t>(kHeadingGapS * 1e6);
  auto at = [&](int64_t t) {
    // The samples around t (the last two past the end: extrapolated at their rate).
    auto b = std::lower_bound(headings_.begin(), headings_.end(), t,
                              [](const HeadingSample& h, int64_t u) { return h.utime < u; });
    if (b == headings_.end()) --b;
    if (b == headings_.begin()) ++b;
    // Inside a gap of lost messages (one integration): extrapolated from the nearer side's
    // samples, not interpolated across the gap (in a turn, the rate is not constant over it).
    if (b->utime - std::prev(b)->utime > gap) {
      const bool nearer_before = t - std::prev(b)->utime <= b->utime - t;
      if (nearer_before && std::prev(b) != headings_.begin())
        --b;
      else if (!nearer_before && std::next(b) != headings_.end())
        ++b;
    }
    const HeadingSample& p = *std::prev(b);
    const double f = static_cast<double>(t - p.utime) / static_cast<double>(b->utime - p.utime);
    return p.heading_rad + f * (b->heading_rad - p.heading_rad);
  };
  const double dt = static_cast<double>(t1 - t0) * 1e-6;
  const double sb = headings_.back().rate_sigma;
  // The span past the newest heading, extrapolated
  // (TrackerOptions::heading_extrapolation_rate_sigma_rad_s).
  const double tau =
      static_cast<double>(std::max<int64_t>(0, t1 - std::max(t0, headings_.back().utime))) * 1e-6;
  const double extrapolated = o_.heading_extrapolation_rate_sigma_rad_s * tau;
  return std::make_pair(at(t1) - at(t0), sb * sb * dt * o_.gyro_bias_correlation_s +
                                             o_.gyro_noise_density * o_.gyro_noise_density * dt +
                                             extrapolated * extrapolated);
}

Mat6 Tracker::symmetric(const Mat6& m) { return 0.5 * (m + m.transpose()); }

UncertainPose Tracker::delta() const { return core::compound(base_, pending_); }

void Tracker::reset(const UncertainPose& active_T_body) {
  // Δ = base ⊕ pending must equal the new value; the pending VO offset stays (its keyframe
  // is still VO's reference), so the base absorbs its inverse. The pending covariance is
  // measured from the keyframe and is counted again from here: conservative.
  base_.mean = active_T_body.mean * pending_.mean.inverse();
  base_.covariance = active_T_body.covariance;
}

void Tracker::addHeight(double dz_m, double sigma_m) {
  // A vertical displacement in the world; the body is level to the IMU's accuracy, so it is
  // the same displacement in the body frame and commutes with the pending VO offset.
  UncertainPose lift;
  lift.mean = SE3d(core::SO3d(), core::Vec3(0, 0, dz_m));
  lift.covariance(2, 2) = sigma_m * sigma_m;
  base_ = core::compound(base_, lift);
}

std::optional<UncertainPose> Tracker::sinceKeyframe(int64_t keyframe_utime) const {
  // The commit point at the keyframe is the increment that ends there.
  auto it = history_.end();
  for (auto h = history_.rbegin(); h != history_.rend(); ++h) {
    if (h->utime == keyframe_utime) {
      it = h.base();  // the element after *h
      break;
    }
    if (h->utime < keyframe_utime) break;
  }
  if (it == history_.end() && (history_.empty() || history_.back().utime != keyframe_utime))
    return std::nullopt;
  UncertainPose out;
  for (; it != history_.end(); ++it) out = core::compound(out, it->pose);
  return core::compound(out, pending_);
}

}  // namespace evermap::mapper
